"""Report figures as inline SVG strings (matplotlib, no pyplot global state, no JavaScript).

Every function takes plain arrays in the report's units (mm, deg) and returns one ``<svg>``
element; ids inside are made unique per figure so several SVGs can share one HTML page.
"""

from __future__ import annotations

import io
import itertools
import re

import numpy as np

try:
    from matplotlib import colors as mcolors
    from matplotlib.figure import Figure
    from matplotlib.ticker import FuncFormatter, MaxNLocator, NullFormatter
except ImportError as exc:  # pragma: no cover - exercised only without the extra
    from robocal.core.errors import RobocalError

    raise RobocalError("the HTML report needs matplotlib: pip install 'robocal[report]'") from exc

BEFORE, AFTER, VALIDATION = "#d95f02", "#1b9e77", "#7570b3"
REJECTED = "#e7298a"
# Scatters with more points than this are drawn as an embedded image (SVG paths of thousands of
# markers made a 1500-point report 3 MB), at RASTER_DPI; axes, labels and text stay vector.
MAX_VECTOR_POINTS = 400
RASTER_DPI = 100
CMAP = "viridis"
# text.parse_math off: a "$" in a user's text (a parameter, file or unit name) is shown as it is,
# never parsed as mathtext (which fails on unbalanced or unknown $...$ input)
_RC = {"text.parse_math": False, "svg.fonttype": "none", "svg.hashsalt": "robocal", "font.size": 9,
       "axes.grid": True, "grid.alpha": 0.3, "axes.spines.top": False, "axes.spines.right": False}
_counter = itertools.count()


def _figure(w: float, h: float, left: float = 0.8, right: float = 0.2, bottom: float = 0.5,
            top: float = 0.15, wspace: float = 0.25, hspace: float = 0.5) -> Figure:
    """A figure with fixed margins in inches (constrained layout costs seconds per figure)."""
    fig = Figure(figsize=(w, h))
    fig.subplots_adjust(left=left / w, right=1 - right / w, bottom=bottom / h, top=1 - top / h,
                        wspace=wspace, hspace=hspace)
    return fig


def _plain_log_labels(fig: Figure) -> None:
    """Log axes labelled 0.01, 0.1, 1 (matplotlib's default labels are mathtext, which
    text.parse_math off would print raw); minor ticks labelled only on an axis under a decade."""
    plain = FuncFormatter(lambda v, _: f"{v:g}")
    for ax in fig.axes:
        for axis, scale in ((ax.xaxis, ax.get_xscale()), (ax.yaxis, ax.get_yscale())):
            if scale != "log":
                continue
            lo, hi = sorted(axis.get_view_interval())
            axis.set_major_formatter(plain)
            axis.set_minor_formatter(plain if lo > 0 and hi / lo < 10 else NullFormatter())


def to_svg(fig: Figure) -> str:
    """One figure as an ``<svg>`` element with figure-unique ids (no XML prolog, no dates)."""
    import matplotlib

    _plain_log_labels(fig)
    buf = io.StringIO()
    with matplotlib.rc_context(_RC):
        fig.savefig(buf, format="svg", dpi=RASTER_DPI, metadata={"Date": None, "Creator": None})
    text = buf.getvalue()
    text = text[text.index("<svg"):]
    prefix = f"f{next(_counter)}-"
    text = re.sub(r'id="([^"]+)"', lambda m: f'id="{prefix}{m.group(1)}"', text)
    text = re.sub(r"url\(#([^)]+)\)", lambda m: f"url(#{prefix}{m.group(1)})", text)
    return re.sub(r'href="#([^"]+)"', lambda m: f'href="#{prefix}{m.group(1)}"', text)


def _styled(build):
    """Build the figure inside the report's rc context (fonts, grid) and return its SVG."""
    import matplotlib

    def wrapper(*args, **kwargs) -> str:
        with matplotlib.rc_context(_RC):
            return to_svg(build(*args, **kwargs))

    wrapper.__doc__ = build.__doc__
    wrapper.__name__ = build.__name__
    return wrapper


def _wide(values: np.ndarray) -> bool:
    """Whether positive ``values`` span more than a factor 20 (then a log axis reads better)."""
    pos = values[values > 0]
    return pos.size == values.size and pos.size > 1 and pos.max() / pos.min() > 20


def _log_if_wide(ax, values: np.ndarray, which: str) -> None:
    if _wide(values):
        (ax.set_yscale if which == "y" else ax.set_xscale)("log")


def _legend_above(ax, **kwargs) -> None:
    """The legend in a row above the axes, on the white margin: never over the data, so no
    swatch is seen through another series' fill."""
    ax.legend(loc="lower right", bbox_to_anchor=(1.0, 1.0), ncols=4, frameon=False, borderaxespad=0.2,
              **kwargs)


@_styled
def sorted_errors(before: np.ndarray, after: np.ndarray, label: str = "position error (mm)") -> Figure:
    """Per-observation errors ``(N,)`` before and after, each sorted descending (bars/lines)."""
    fig = _figure(6.4, 3.0, top=0.35)
    ax = fig.add_subplot()
    x = np.arange(1, before.size + 1)
    if before.size <= 120:
        ax.bar(x, np.sort(before)[::-1], width=0.9, color=BEFORE, alpha=0.55, label="before")
        ax.bar(x, np.sort(after)[::-1], width=0.9, color=AFTER, label="after")
    else:
        dense = before.size > MAX_VECTOR_POINTS
        ax.fill_between(x, np.sort(before)[::-1], step="mid", color=BEFORE, alpha=0.45, label="before",
                        rasterized=dense)
        ax.fill_between(x, np.sort(after)[::-1], step="mid", color=AFTER, alpha=0.9, label="after",
                        rasterized=dense)
    _log_if_wide(ax, np.concatenate([before, after]), "y")
    ax.set_xlabel("observations, sorted by error")
    ax.set_ylabel(label)
    ax.set_xlim(0.4, before.size + 0.6)
    _legend_above(ax)
    return fig


@_styled
def distribution(series: list[tuple[str, np.ndarray, str]], label: str = "position error (mm)",
                 shares: bool = False) -> Figure:
    """Histogram and cumulative distribution of error series ``(name, values (N,), colour)``;
    ``shares``: each set's histogram as its share per bin (%), so sets of different sizes compare."""
    fig = _figure(6.4, 3.0, wspace=0.32, top=0.35)
    hist, cdf = fig.subplots(1, 2)
    allv = np.concatenate([values for _, values, _ in series])
    pos = allv[allv > 0]
    if _wide(allv):
        bins = np.geomspace(pos.min() * 0.98, pos.max() * 1.02, 40)
        hist.set_xscale("log")
        cdf.set_xscale("log")
    else:
        bins = np.linspace(0.0, float(allv.max()) * 1.02 if allv.size and allv.max() > 0 else 1.0, 40)
    for name, values, colour in series:
        weights = np.full(values.size, 100.0 / max(values.size, 1)) if shares else None
        hist.hist(values, bins=bins, weights=weights, color=colour, alpha=0.6, label=name)
        xs = np.sort(values)
        cdf.step(xs, np.arange(1, xs.size + 1) / xs.size * 100.0, where="post", color=colour, label=name)
    hist.set_xlabel(label)
    hist.set_ylabel("share of the set (%)" if shares else "count")
    cdf.set_xlabel(label)
    cdf.set_ylabel("observations below (%)")
    cdf.set_ylim(0, 101)
    cdf.axhline(95, color="grey", lw=0.8, ls="--")
    _legend_above(cdf, fontsize=8)
    return fig


JOINT_BINS = 12  # bins (equal counts) of each joint's angles for the mean-error line of error_vs_joints


def _binned_mean(x: np.ndarray, y: np.ndarray, bins: int) -> tuple[np.ndarray, np.ndarray]:
    """The mean of ``x`` and of ``y`` in each of ``bins`` bins of ``x`` holding equal numbers of
    points (quantiles: a bin of the range with one or two poses would make the line jump)."""
    edges = np.quantile(x, np.linspace(0.0, 1.0, bins + 1))
    k = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, bins - 1)
    count = np.bincount(k, minlength=bins)
    keep = count > 0
    mean_x = np.bincount(k, weights=x, minlength=bins)[keep] / count[keep]
    return mean_x, np.bincount(k, weights=y, minlength=bins)[keep] / count[keep]


@_styled
def error_vs_joints(joints_deg: np.ndarray, after: np.ndarray, label: str = "error (mm)",
                    rejected: np.ndarray | None = None,
                    joints: list[tuple[str, str]] | None = None) -> Figure:
    """Error after calibration ``(N,)`` against each joint of ``joints_deg`` ``(N, n)`` (deg; mm on
    a prismatic joint), on a linear scale, with the mean per bin of equally many poses; ``joints``
    names each ``(name, unit)`` (default ``q1..qn`` in deg); ``rejected`` observations are left out
    (their errors would set the scale)."""
    keep = np.ones(after.size, bool) if rejected is None else ~np.asarray(rejected, bool)
    q, e = joints_deg[keep], after[keep]
    n = joints_deg.shape[1]
    joints = joints or [(f"q{j + 1}", "deg") for j in range(n)]
    cols = 3
    rows = -(-n // cols)
    fig = _figure(6.4, 1.75 * rows + 0.35, top=0.3, hspace=0.65, wspace=0.08, left=0.75)
    axes = np.atleast_1d(fig.subplots(rows, cols, sharey=True)).reshape(-1)
    dense = e.size > MAX_VECTOR_POINTS
    for j, ax in enumerate(axes):
        if j >= n:
            ax.set_visible(False)
            continue
        ax.scatter(q[:, j], e, s=5, color=AFTER, alpha=0.55, lw=0, label="after", rasterized=dense)
        if e.size:
            xc, mean = _binned_mean(q[:, j], e, JOINT_BINS)
            ax.plot(xc, mean, color="#0b4f3c", lw=1.6, label="mean per bin")
        ax.set_xlabel(f"{joints[j][0]} ({joints[j][1]})")
        if j % cols == 0:
            ax.set_ylabel(label)
    if e.size:
        axes[0].set_ylim(0, float(np.percentile(e, 99.5)) * 1.1 or 1.0)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="upper right", ncols=2, frameon=False,
               markerscale=2)
    return fig


@_styled
def points_3d(points: np.ndarray, values: np.ndarray, label: str,
              rejected: np.ndarray | None = None) -> Figure:
    """3-D scatter of ``points`` ``(N, 3)`` (mm) coloured by ``values`` ``(N,)``; ``rejected`` (N,)
    marks points drawn as crosses and left out of the colour scale."""
    fig = _figure(6.0, 4.6, left=0.0, right=0.0, bottom=0.0, top=0.0)
    ax = fig.add_subplot(projection="3d")
    rejected = np.zeros(len(points), bool) if rejected is None else np.asarray(rejected, bool)
    keep = ~rejected if (~rejected).any() else np.ones(len(points), bool)
    norm = mcolors.Normalize(float(values[keep].min()), float(values[keep].max()))
    sc = ax.scatter(points[keep, 0], points[keep, 1], points[keep, 2], c=values[keep], cmap=CMAP, norm=norm,
                    s=9, depthshade=False, rasterized=bool(keep.sum() > MAX_VECTOR_POINTS))
    if rejected.any():
        ax.scatter(points[rejected, 0], points[rejected, 1], points[rejected, 2], marker="x", s=25,
                   color=REJECTED, depthshade=False, label="rejected")
        ax.legend(frameon=False, loc="upper left")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    _equal_3d(ax, points)
    fig.colorbar(sc, ax=ax, shrink=0.6, pad=0.12, label=label)
    return fig


def _equal_3d(ax, points: np.ndarray) -> None:
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre, half = (lo + hi) / 2, max(float((hi - lo).max()) / 2, 1e-9)
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)


def magnification(scale: float) -> str:
    """A drawing scale factor in words, 3 significant digits: ``7290x``, ``12.5x``."""
    return f"{float(f'{scale:.3g}'):g}x"


@_styled
def worst_vectors(points: np.ndarray, residuals: np.ndarray, worst: np.ndarray) -> Figure:
    """All ``points`` (N, 3) in grey and, at the ``worst`` indices, the residual vectors
    (measured - model, mm) scaled so the longest is 15 % of the workspace size."""
    fig = _figure(5.2, 4.6, left=0.0, right=0.0, bottom=0.0, top=0.3)
    ax = fig.add_subplot(projection="3d")
    ax.scatter(points[:, 0], points[:, 1], points[:, 2], color="#bbbbbb", s=4, depthshade=False,
               rasterized=bool(len(points) > MAX_VECTOR_POINTS))
    p, r = points[worst], residuals[worst]
    longest = float(np.linalg.norm(r, axis=1).max()) if worst.size else 0.0
    size = float((points.max(axis=0) - points.min(axis=0)).max()) or 1.0
    scale = 0.15 * size / longest if longest > 0 else 1.0
    ax.quiver(p[:, 0], p[:, 1], p[:, 2], r[:, 0] * scale, r[:, 1] * scale, r[:, 2] * scale,
              color="#e7298a", lw=1.5, arrow_length_ratio=0.25)
    ax.scatter(p[:, 0], p[:, 1], p[:, 2], color="#e7298a", s=14, depthshade=False)
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    ax.set_title(f"arrows magnified {magnification(scale)}", fontsize=9)
    _equal_3d(ax, points)
    return fig


@_styled
def correlation(names: list[str], matrix: np.ndarray) -> Figure:
    """Heat map of a correlation matrix ``(k, k)`` in [-1, 1] with parameter names."""
    k = len(names)
    side = float(np.clip(0.16 * k + 1.6, 3.5, 9.0))
    margin = 0.9 if k <= 30 else 0.7
    fig = _figure(side + 1.2, side, left=margin, bottom=margin, right=0.1, top=0.1)
    ax = fig.add_subplot()
    im = ax.imshow(matrix, cmap="RdBu_r", norm=mcolors.Normalize(-1, 1), interpolation="nearest")
    ax.grid(False)
    fontsize = 9 if k <= 24 else 7 if k <= 40 else 5  # 9 pt reads at the report's column width
    ax.set_xticks(range(k), names, rotation=90, fontsize=fontsize)
    ax.set_yticks(range(k), names, fontsize=fontsize)
    fig.colorbar(im, ax=ax, shrink=0.8, label="correlation")
    return fig


@_styled
def history(iterations: np.ndarray, values: np.ndarray, label: str, before: float | None = None) -> Figure:
    """Solver history: ``values`` ``(m,)`` against ``iterations`` (log scale when positive and
    wide), with the error ``before`` calibration as a dashed line when given."""
    fig = _figure(6.4, 2.6, top=0.35)
    ax = fig.add_subplot()
    ax.plot(iterations, values, "o-", color=AFTER, ms=3, label="best estimate")
    span = values if before is None else np.append(values, before)
    if before is not None:
        ax.axhline(before, color=BEFORE, lw=1.2, ls="--", label="before calibration")
    if (span > 0).all() and span.max() / max(span.min(), 1e-300) > 20:
        ax.set_yscale("log")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("iteration")
    ax.set_ylabel(label)
    _legend_above(ax)
    return fig


@_styled
def accuracy_curve(n: np.ndarray, planned: np.ndarray, random: np.ndarray,
                   chosen: int | None = None) -> Figure:
    """Predicted accuracy (mm) against the number of poses ``n``: planned and random designs."""
    fig = _figure(7.5, 3.2)
    ax = fig.add_subplot()
    ax.plot(n, random, "o-", color=BEFORE, ms=3, label="random poses (median)")
    ax.plot(n, planned, "o-", color=AFTER, ms=3, label="planned poses")
    if chosen is not None:
        ax.axvline(chosen, color="grey", lw=0.8, ls="--")
    _log_if_wide(ax, np.concatenate([planned, random]), "y")
    ax.set_xlabel("number of poses")
    ax.set_ylabel("predicted RMS error (mm)")
    ax.legend(frameon=False)
    return fig


@_styled
def error_vs_distance(distance: np.ndarray, predicted: np.ndarray, validated: float, factor: float,
                      unit: str = "deg") -> Figure:
    """Predicted RMS error (mm) of the workspace sample against its joint distance (``unit``: deg,
    or e.g. ``deg; mm on q3`` with a prismatic joint) to the nearest calibration pose, with the
    validated error and ``factor`` times it as lines."""
    fig = _figure(6.4, 2.8, top=0.35)
    ax = fig.add_subplot()
    ax.plot(distance, predicted, "o-", color=BEFORE, ms=3, label="predicted over the workspace")
    ax.axhline(validated, color=AFTER, lw=1.2, label="validated")
    ax.axhline(factor * validated, color="grey", lw=0.8, ls="--", label=f"{factor:g} x validated")
    _log_if_wide(ax, np.append(predicted, validated), "y")
    ax.set_xlabel(f"joint distance to the nearest calibration pose ({unit})")
    ax.set_ylabel("predicted RMS error (mm)")
    _legend_above(ax)
    return fig

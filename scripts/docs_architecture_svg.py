"""Draws docs/explanation/architecture.svg: the layers of tests/test_layers.py (bottom to top) with
the steps of a calibration and of a program filter placed on the layer that does them.

``python scripts/docs_architecture_svg.py docs/explanation/architecture.svg`` after a change of
the layers.
"""

from __future__ import annotations

import sys
from html import escape
from pathlib import Path

LAYERS = [  # (packages, what), bottom to top
    (["core"], "errors, atomic files, YAML, units, least squares"),
    (["kinematics"], "the robot model, FK, Jacobians, catalog, URDF"),
    (["data", "ik"], "measurements, import, simulation | IK, paths"),
    (["identify"], "the problem, parameters, priors, solvers"),
    (["trust", "report"], "tests, predictions, diagnosis | the report"),
    (["calibration"], "the pipeline, its result, the error model"),
    (["deploy"], "compensation, the tool, the model pair"),
    (["programs"], "the filter engine, dialects/<language>"),
    (["campaign", "history"], "pose planning | a robot's history, checks"),
    (["demo"], "the demo job"),
    (["cli"], "parse, one API call, print, write"),
]
FLOWS = [  # (title, colour, steps: (layer, label))
    ("robocal calibrate", "#b5472d", [("cli", "1 parse"), ("calibration", "2 calibrate()"),
                                       ("data", "3 read, register"), ("identify", "4 solve"),
                                       ("trust", "5 test, predict"), ("calibration", "6 result"),
                                       ("cli", "7 summary, write")]),
    ("robocal filter", "#2d7f5e", [("cli", "1 parse"), ("deploy", "2 model pair"),
                                    ("programs", "3 read (dialect)"), ("kinematics", "4 FK"),
                                    ("deploy", "5 compensate"), ("programs", "6 edit, mark"),
                                    ("cli", "7 summary, write")]),
]
BOX_W, BOX_H, LEFT, GAP, TOP, FLOW_W = 430, 40, 10, 6, 20, 150  # px of the drawing


def layer_boxes(out: list[str]) -> dict[str, float]:
    """Draw the layers; the top y of each package's box."""
    rows = {}
    for k, (packages, what) in enumerate(LAYERS):
        y = TOP + (len(LAYERS) - 1 - k) * (BOX_H + GAP)
        rows.update(dict.fromkeys(packages, y))
        names = "   ·   ".join(p + "/" for p in packages)
        out += [f'<rect x="{LEFT}" y="{y}" width="{BOX_W}" height="{BOX_H}" rx="6" fill="#eef3fb" '
                'stroke="#4a6fa5"/>',
                f'<text x="{LEFT + 12}" y="{y + 18}" font-weight="bold">{escape(names)}</text>',
                f'<text x="{LEFT + 12}" y="{y + 33}" fill="#333" font-size="13">{escape(what)}</text>']
    return rows


def flow(out: list[str], x: float, rows: dict[str, float], title: str, colour: str, steps, bottom: float):
    """Draw one flow's numbered steps at ``x``, joined by arrows, its title at ``bottom``."""
    out.append(f'<text x="{x}" y="{bottom}" fill="{colour}" font-weight="bold">{escape(title)}</text>')
    points = [(x + 6 + (i % 2) * 8, rows[layer] + (12 if i < len(steps) / 2 else 32))
              for i, (layer, _) in enumerate(steps)]
    for (x1, y1), (x2, y2) in zip(points, points[1:], strict=False):
        middle = (y1 + y2) / 2
        out.append(f'<path d="M{x1},{y1} C{x1 - 14},{middle} {x2 - 14},{middle} {x2},{y2}" fill="none" '
                   f'stroke="{colour}" stroke-width="1.8" marker-end="url(#arrow)"/>')
    for (px, py), (_, label) in zip(points, steps, strict=True):
        out += [f'<circle cx="{px}" cy="{py}" r="3.5" fill="{colour}"/>',
                f'<text x="{px + 10}" y="{py + 4}" fill="{colour}">{escape(label)}</text>']


def drawing() -> str:
    """The SVG text."""
    height = TOP + len(LAYERS) * (BOX_H + GAP) + 40
    width = LEFT + BOX_W + 20 + FLOW_W * len(FLOWS)
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {width} {height}" width="100%" '
           'font-family="sans-serif" font-size="14" role="img" '
           'aria-label="robocal layers, and the flows of a calibration and of a program filter">',
           '<defs><marker id="arrow" viewBox="0 0 10 10" refX="9" refY="5" markerWidth="6" markerHeight="6" '
           'orient="auto"><path d="M0,0 L10,5 L0,10 z" fill="#555"/></marker></defs>']
    rows = layer_boxes(out)
    for k, (title, colour, steps) in enumerate(FLOWS):
        flow(out, LEFT + BOX_W + 20 + k * FLOW_W, rows, title, colour, steps, height - 14)
    return "\n".join(out + ["</svg>"]) + "\n"


if __name__ == "__main__":
    Path(sys.argv[1]).write_text(drawing())

"""The instruments that measure a robot, and the noise each documents: the one registry of them.

A measurement set is taken with one instrument (:attr:`robocal.data.measurements.Measurements.
instrument`: the CSV's ``# instrument: NAME`` comment line, ``--instrument NAME`` on the command
line, or ``instrument=`` in the API). The instrument gives what the data alone do not say:

- the 1-sigma noise of a row when the data carry no sigma column and none is given (a position
  in m, an orientation in rad for the 6-D kinds), i.e. the weight of the set against others and
  the start of the prior's noise scale;
- whether its errors are heavy-tailed (a marker swapped or occluded, a board detected at a grazing
  angle): then the calibration's default method is ``robust`` (IGG3 reweighting,
  :mod:`robocal.identify.robust`) instead of ``lsq``; a method named explicitly is kept.

An empty instrument name means "not declared": the kind's own default noise applies
(`robocal.data.kinds.KindSpec.sigma_m`) and the default method is ``lsq``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from robocal.core.errors import DataError


@dataclass(frozen=True)
class Instrument:
    """One instrument's documented noise.

    Attributes
    ----------
    name : str
        Its name (``tracker``, ``mocap``, ``camera``).
    sigma_m : float
        1-sigma noise of one measured position, m.
    sigma_rad : float
        1-sigma noise of one measured orientation (each axis), rad; inf when it measures none.
    heavy_tailed : bool
        Its errors have heavier tails than a Gaussian: the default method is ``robust``.
    kinds : tuple of str
        The measurement kinds it takes.
    source : str
        Where the figures come from.
    """

    name: str
    sigma_m: float
    sigma_rad: float
    heavy_tailed: bool
    kinds: tuple[str, ...]
    source: str

    @property
    def length_scale(self) -> float:
        """m per rad that makes an orientation residual weigh like a position one,
        ``sigma_m / sigma_rad`` (0 when it measures no orientation)."""
        return self.sigma_m / self.sigma_rad if self.sigma_rad < float("inf") else 0.0


INSTRUMENTS = {i.name: i for i in (
    # Leica AT960 datasheet: MPE U_xyz = +-(15 um + 6 um/m), i.e. ~20-30 um at 2-4 m (a 2-sigma
    # MPE; the tracker kinds' KindSpec.sigma_m take 20 um)
    Instrument("tracker", sigma_m=20e-6, sigma_rad=float("inf"), heavy_tailed=False,
               kinds=("point", "pose", "distance"),
               source="Leica Absolute Tracker AT960 datasheet (2015): MPE +-(15 um + 6 um/m)"),
    # passive-marker optical motion capture: Merriaux et al., "A Study of Vicon System Positioning
    # Performance", Sensors 17(7):1591, 2017 (static errors ~0.1-0.2 mm, moving ~0.3-0.5 mm);
    # Eichelberger et al., J. Biomech. 49(10):2085-2088, 2016 (0.1-0.5 mm by set-up). Markers swap
    # or are partly occluded: heavy tails.
    Instrument("mocap", sigma_m=0.3e-3, sigma_rad=float("inf"), heavy_tailed=True,
               kinds=("point", "marker"),
               source="Merriaux et al., Sensors 17(7):1591 (2017); Eichelberger et al., J. Biomech. "
                      "49:2085 (2016): 0.1-0.5 mm per marker"),
    # a camera estimating a checkerboard's pose (PnP after Zhang's calibration, 0.1-0.3 px
    # reprojection error): Zhang, IEEE PAMI 22(11):1330-1334, 2000; hand-eye set-ups report
    # 0.5-2 mm and 0.1-0.5 deg per pose (Tsai & Lenz, IEEE Trans. Robot. Autom. 5(3):345-358,
    # 1989; Horaud & Dornaika, IJRR 14(3):195-210, 1995). Depth is the weak direction; a board
    # seen at a grazing angle or a wrong corner ordering gives gross errors: heavy tails.
    Instrument("camera", sigma_m=1e-3, sigma_rad=0.005, heavy_tailed=True,
               kinds=("point", "pose", "eye_to_hand", "eye_in_hand"),
               source="Zhang, IEEE PAMI 22:1330 (2000); Tsai & Lenz, IEEE TRA 5:345 (1989); Horaud & "
                      "Dornaika, IJRR 14:195 (1995): 0.5-2 mm and 0.1-0.5 deg per board pose"),
)}


# the instrument a kind implies when the data declare none (only it measures such rows)
IMPLIED = {"marker": "mocap", "eye_to_hand": "camera", "eye_in_hand": "camera"}


def instrument_of(data) -> str:
    """The instrument of a measurement set: the one it declares, else the one its kind implies
    (`IMPLIED`), else "" (undeclared)."""
    return data.instrument or IMPLIED.get(data.kind, "")


def instrument_spec(name: str) -> Instrument:
    """The instrument called ``name``; DataError for an unknown one (naming the known ones)."""
    if name not in INSTRUMENTS:
        raise DataError(f"unknown instrument {name!r}: use one of {', '.join(INSTRUMENTS)}")
    return INSTRUMENTS[name]


def check_instrument(name: str, kind: str) -> str:
    """``name`` if the instrument exists and takes ``kind`` (``""``: none declared); DataError else."""
    if not name:
        return ""
    inst = instrument_spec(name)
    if kind not in inst.kinds:
        raise DataError(f"a {name} does not measure {kind} rows (it measures {', '.join(inst.kinds)}): "
                        "declare the instrument that took the data")
    return name


def declared(sets: list, name: str | None) -> list:
    """Measurement sets with the instrument ``name`` declared on those that declare none
    (``name`` None or "": as they are); DataError for a set that declares another one."""
    if not name:
        return list(sets)
    out = []
    for d in sets:
        if d.instrument and d.instrument != name:
            raise DataError(f"{d.label or 'a data set'} declares the instrument {d.instrument!r}, not "
                            f"{name!r}: remove its '# instrument:' line or the instrument option")
        out.append(replace(d, instrument=check_instrument(name, d.kind)))
    return out


def default_method(sets: list) -> str:
    """The calibration method for ``sets`` when none is named: ``robust`` when an instrument with
    heavy-tailed errors took one of them, else ``lsq``."""
    heavy = any(instrument_of(d) and INSTRUMENTS[instrument_of(d)].heavy_tailed for d in sets)
    return "robust" if heavy else "lsq"


def noise_of(data) -> float:
    """1-sigma noise (m) of a set's rows without a sigma column: its instrument's, else its kind's."""
    return INSTRUMENTS[instrument_of(data)].sigma_m if instrument_of(data) else data.spec.sigma_m

"""Flush contacts: a flat tool face pressed onto a plane (a table), only the joints recorded.

At each contact the tool face lies in the plane, which fixes three things of the TCP frame:
its height along the plane's normal and two angles (the face normal parallel to the plane's
normal). FIGAROH's TALOS table-contact calibration measures the same ``[z, roll, pitch]``.

The face is the model's tool: its centre is the TCP (``tool.x/y/z``) and its normal the tool
frame's z axis (the model file's ``tool: {xyz, rpy}``; either sense of the normal). The world
frame is the robot model's (its base frame), in which the planes are expressed. Three residuals
per contact, measured minus modelled (what is measured is a perfect contact: zero height, zero
tilt):

- ``-h``: the signed orthogonal distance ``h`` of the TCP to its plane (m), as for ``plane``;
- ``-L t_u`` and ``-L t_v``: the face normal's tilt from the plane's normal in the plane's two
  coordinate planes (``t_u = atan(z_u / z_d) + atan(a)``, rad; for a table with the normal along
  z these are the roll and pitch of the face), times ``TILT_LENGTH_M``
  (`robocal.data.kinds.FLUSH_TILT_LENGTH_M`, 50 mm): the lift of the rim
  of a face of that radius, so the three rows are lengths with one noise (the kind's
  ``sigma_mm``: 10 um lifts the rim of a 50 mm face by a 0.2 mrad tilt). A contact's error (the
  statistics, ``evaluate``) is the norm of the three.

Plane ``k`` is ``p_d = a p_u + b p_v + c`` (nuisance ``plane{k}.a/b/c``, c in m), the
parametrisation of :mod:`robocal.identify.observations.plane`; the dependent axis ``d`` is the
coordinate axis closest to the plane's face normals (their mean over its contacts at the model
the observation is built with). The start of the planes and the metaheuristics' profiled cost
(:meth:`FlushObservation.profiled_residuals_batch`) fit the planes to the modelled faces
(:meth:`FlushObservation.fit_flush`: weighted least squares of the three rows).

What flush contacts cannot see (``params='auto'`` leaves it out, :func:`not_observable`):

- the base frame ``base.*`` (the planes are expressed in it) and the scale (every length scaled
  about the base origin keeps every contact flush): the longest nominal link is held, as for
  ``plane``;
- the tool face's position ``tool.x, tool.y, tool.z``: moving the face within its own plane
  moves no contact off its plane, and moving it along its normal shifts every contact of a plane
  by the same height, which the plane's offset takes;
- the last link's ``d_n`` (a translation fixed in the flange frame, like the tool's);
- the rotation of the face about its own normal: ``tool.rz`` when the normal is the flange's z
  (within ``FACE_AXIS_TOL_RAD``, 1 deg), that axis's rotation for a normal along another flange
  axis, else the identifiability analysis holds that combination. With the normal along the
  flange's z, the last joint's axis, also that joint's zero ``theta_n`` (a rotation about the
  normal) and ``a_n`` (a translation along ``x_{n-1}``, perpendicular to the last axis: always
  within the face's plane); when the last twist is square as well (``z_{n-1}`` perpendicular to
  ``z_n`` within ``FACE_AXIS_TOL_RAD``: a spherical wrist), ``d_{n-1}``, a translation along
  ``z_{n-1}`` that is always within the face's plane too (its column is the round-off of the
  faces' small tilts: held by its prior, it would predict its prior's error over the workspace).
"""

from __future__ import annotations

import numpy as np

from robocal.core.errors import IdentificationError
from robocal.data.kinds import FLUSH_TILT_LENGTH_M as TILT_LENGTH_M
from robocal.identify.observations.plane import PlaneObservation, scale_reference

# A face normal within this angle (rad) of a flange axis (a face mounted square, with its mounting
# error): its spin is that axis's tool rotation, named as not observable with the last joint's
# zero and a_n when the axis is the flange's z (the data see them only through the small tilt)
FACE_AXIS_TOL_RAD = np.deg2rad(1.0)
# At the model a calibration starts from, a face beyond these from flush on the plane fitted to its
# plane's contacts is not a robot error (nominal models tilt a face by well below 1 deg and miss by
# a few mm): a contact on another plane, not flush, or the face normal given wrong
MAX_START_TILT_RAD = np.deg2rad(5.0)
MAX_START_HEIGHT_M = 0.02
PLANE_FIT_ITERATIONS = 3  # Gauss-Newton steps of a plane fit from its closed-form start (3 reach 1e-15)


def face_normal_axis(robot) -> int | None:
    """The flange axis (0, 1, 2) the tool face's normal (the tool's z) lies along (within
    `FACE_AXIS_TOL_RAD`), or None."""
    normal = np.abs(robot.tool[:3, 2])
    axis = int(np.argmax(normal))
    return axis if normal[axis] >= np.cos(FACE_AXIS_TOL_RAD) else None


def not_observable(robot) -> list[str]:
    """Parameters flush contacts can never identify: ``base.*``, the scale reference, the tool
    translation and the last link's ``d_n`` (a translation fixed in the flange frame); when the face
    normal lies along a flange axis, the tool's rotation about it, and when that axis is the last
    joint's (flange z) also that joint's zero ``theta_n`` and ``a_n`` (a translation along
    ``x_{n-1}``, always in the face's plane), and with a square last twist also ``d_{n-1}`` (along
    ``z_{n-1}``, in the face's plane too)."""
    n = robot.n_joints
    names = [f"base.{f}" for f in ("x", "y", "z", "rx", "ry", "rz")] + [scale_reference(robot)]
    names += ["tool.x", "tool.y", "tool.z", f"d{n}"]
    axis = face_normal_axis(robot)
    if axis is not None:
        names.append(f"tool.r{'xyz'[axis]}")
    if axis == 2:
        names += [f"a{n}", f"theta{n}"]
        if n > 1 and abs(np.cos(robot.get(f"alpha{n}"))) < np.sin(FACE_AXIS_TOL_RAD):
            names.append(f"d{n - 1}")
    return list(dict.fromkeys(names))


class FlushObservation(PlaneObservation):
    """Flush contacts of the tool face with planes: height and two tilt residuals per contact."""

    kind = "flush"
    rows_per_item = 3
    blind_spot = ("flush contacts carry no length reference and do not see the base frame, the tool "
                  "face's position nor its rotation about its normal")

    def __init__(self, data, robot) -> None:
        super(PlaneObservation, self).__init__(data, robot)
        self._index_planes(data, "flush contacts use the tool face (the TCP and the tool's z axis)")
        T = self._fk(robot)  # once: the face normals, then the check's planes and residuals
        z = T[:, :3, 2]
        first = np.argmax(self.onehot, axis=0)  # (K,): each plane's first contact
        sense = np.sign(np.einsum("ni,ni->n", z, z[first[self.plane_of]]))  # either sense of the face
        mean = self.onehot.T @ (z * sense[:, None])  # (K, 3)
        self.dependent_axis = np.argmax(np.abs(mean), axis=1)
        d = self.dependent_axis
        self.perm = np.stack([(d + 1) % 3, (d + 2) % 3, d], axis=1)
        self.nuisance_names = [f"plane{pid}.{c}" for pid in self.plane_ids for c in "abc"]
        self._check_flush(robot, T)

    def _check_flush(self, robot, T: np.ndarray) -> None:
        """IdentificationError when ``robot``'s faces at the contacts of a plane (its TCP frames
        ``T (N, 4, 4)``) are farther from flush on the plane fitted to them than any robot's errors
        explain (`MAX_START_TILT_RAD`, `MAX_START_HEIGHT_M`): a contact numbered with another plane,
        a face not pressed flush, or a face normal that is not the tool's z."""
        m = self.modelled(T, self.fit_flush(T))  # on the planes nuisance_start fits
        tilt, height = np.linalg.norm(m[:, 1:], axis=1) / TILT_LENGTH_M, np.abs(m[:, 0])
        for what, value, limit, unit, scale in (("tilted by", tilt, MAX_START_TILT_RAD, "deg", 180 / np.pi),
                                                ("off the plane by", height, MAX_START_HEIGHT_M, "mm", 1e3)):
            bad = np.flatnonzero(value > limit)
            if bad.size:
                worst = bad[np.argsort(-value[bad])][:5]
                planes = np.unique(self.plane_ids[self.plane_of[bad]]).tolist()
                raise IdentificationError(
                    f"{self.data.label or 'flush contacts'}: with {robot.name} the face is {what} up to "
                    f"{value.max() * scale:.3g} {unit} on plane(s) {planes} (rows "
                    f"{self.data.source_row[worst].tolist()}), beyond {limit * scale:.3g} {unit}: check "
                    "those rows' flush_plane ids and that the face normal is the tool's z axis (the model's "
                    "tool rotation)")

    def not_observable(self, robot) -> list[str]:
        return not_observable(robot)

    def check_enough(self, n_unknowns: int) -> None:
        rows = self.rows_per_item
        if rows * self.n_items <= n_unknowns:
            raise IdentificationError(
                f"{self.n_items} flush contacts ({rows} residuals each) cannot determine {n_unknowns} "
                f"unknowns (robot parameters plus 3 per plane): record more than {n_unknowns // rows} "
                "contacts (3 times as many is better), over each plane and the robot's orientations about "
                "its normal")

    # ---------------------------------------------------------------- geometry
    def _slopes(self, z: np.ndarray) -> np.ndarray:
        """The face normals ``z (..., N, 3)`` as slopes ``(..., N, 2)``: z_u / z_d, z_v / z_d in
        the coordinates of each contact's plane."""
        loc = self._local(z)
        return loc[..., :2] / loc[..., 2:]

    def modelled(self, T: np.ndarray, nuisance: np.ndarray) -> np.ndarray:
        """``(..., N, 3)``: height (m) and the two tilts times `TILT_LENGTH_M` of TCP frames
        ``T (..., N, 4, 4)`` against planes ``nuisance (..., 3K)``."""
        nuisance = np.asarray(nuisance, float)
        h = self.signed_distance(T[..., :3, 3], nuisance)
        coef = nuisance.reshape(nuisance.shape[:-1] + (-1, 3))[..., self.plane_of, :2]  # (..., N, 2)
        tilt = np.arctan(self._slopes(T[..., :3, 2])) + np.arctan(coef)
        return np.concatenate([h[..., None], TILT_LENGTH_M * tilt], axis=-1)

    def plane_columns(self, p: np.ndarray, nuisance: np.ndarray) -> np.ndarray:
        """``(..., N, 3, 3)``: d(height, L tilt_u, L tilt_v)/d(a, b, c of the contact's plane) at
        face centres ``p (..., N, 3)`` and planes ``nuisance (..., 3K)``."""
        nuisance = np.asarray(nuisance, float)
        coef = nuisance.reshape(nuisance.shape[:-1] + (-1, 3))[..., self.plane_of, :]
        a, b = coef[..., 0], coef[..., 1]
        root = np.sqrt(1.0 + a * a + b * b)
        h = self.signed_distance(p, nuisance)
        loc = self._local(p)
        cols = np.zeros(p.shape[:-1] + (3, 3))
        cols[..., 0, 0] = -loc[..., 0] / root - h * a / root**2
        cols[..., 0, 1] = -loc[..., 1] / root - h * b / root**2
        cols[..., 0, 2] = -1.0 / root
        cols[..., 1, 0] = TILT_LENGTH_M / (1.0 + a * a)
        cols[..., 2, 1] = TILT_LENGTH_M / (1.0 + b * b)
        return cols

    def fit_flush(self, T: np.ndarray) -> np.ndarray:
        """The weighted least-squares planes ``(..., 3K)`` of TCP frames ``T (..., N, 4, 4)``
        (vectorised over the leading dims): slopes cancelling the mean tilt of each plane's
        contacts and the offset their mean height, then `PLANE_FIT_ITERATIONS` Gauss-Newton steps
        of the three rows together."""
        W = self.fit_weights / self.fit_weights.sum(axis=0)  # (N, K)
        angle = -np.einsum("nk,...ni->...ki", W, np.arctan(self._slopes(T[..., :3, 2])))  # (..., K, 2)
        ab = np.tan(angle)
        loc = self._local(T[..., :3, 3])
        a, b = ab[..., self.plane_of, 0], ab[..., self.plane_of, 1]
        c = np.einsum("nk,...n->...k", W, loc[..., 2] - a * loc[..., 0] - b * loc[..., 1])
        coef = np.concatenate([ab, c[..., None]], axis=-1)  # (..., K, 3)
        for _ in range(PLANE_FIT_ITERATIONS):
            flat = coef.reshape(coef.shape[:-2] + (-1,))
            m = self.modelled(T, flat)  # (..., N, 3)
            C = self.plane_columns(T[..., :3, 3], flat)  # (..., N, 3, 3)
            G = np.einsum("nk,...nri,...nrj->...kij", self.fit_weights, C, C)
            g = np.einsum("nk,...nri,...nr->...ki", self.fit_weights, C, m)
            coef = coef - np.linalg.solve(G, g[..., None])[..., 0]
        return coef.reshape(coef.shape[:-2] + (-1,))

    # ---------------------------------------------------------------- Observation API
    def nuisance_start(self, robot) -> np.ndarray:
        """The planes fitted to the faces of ``robot`` at the contacts."""
        return self.fit_flush(self._fk(robot))

    def residuals(self, robot, nuisance) -> np.ndarray:
        return -self.modelled(self._fk(robot), nuisance).reshape(-1)

    def jacobian(self, robot, names, nuisance) -> np.ndarray:
        """``(3N, k + 3K)``: d(height, L tilts)/d(robot parameters, plane coefficients)."""
        nuisance = np.asarray(nuisance, float)
        T = self._fk(robot)
        p, z = T[:, :3, 3], T[:, :3, 2]
        N, K = self.n_items, self.plane_ids.size
        J = np.zeros((N, 3, len(names) + 3 * K))
        if len(names):
            J6 = self._tcp_jacobian(robot, names, "pose")  # (N, 6, k): dp, then world rotations w
            normal = self.plane_normals(nuisance)[self.plane_of]
            J[:, 0, : len(names)] = np.einsum("ni,nik->nk", normal, J6[:, :3])
            dz = np.cross(J6[:, 3:], z[:, :, None], axis=1)  # (N, 3, k): w x z
            zl, dzl = self._local(z), np.take_along_axis(dz, self.perm[self.plane_of][:, :, None], axis=1)
            s = zl[:, :2] / zl[:, 2:]
            ds = (dzl[:, :2] * zl[:, 2:, None] - zl[:, :2, None] * dzl[:, 2:]) / zl[:, 2:, None] ** 2
            J[:, 1:, : len(names)] = TILT_LENGTH_M * ds / (1.0 + s**2)[:, :, None]
        cols = self.plane_columns(p, nuisance)  # rows: height, tilt u, tilt v; columns: a, b, c
        J[:, :, len(names):] = (self.onehot[:, None, :, None] * cols[:, :, None, :]).reshape(N, 3, 3 * K)
        return J.reshape(3 * N, -1)

    def residuals_batch(self, robot, names, X, nuisance=None) -> np.ndarray:
        """Residuals ``(P, 3N)`` of displaced robots ``X (P, k)`` against fixed planes ``nuisance``."""
        T = self.batch_tcp(robot, names, X)
        return -self.modelled(T, nuisance).reshape(X.shape[0], -1)

    def profiled_residuals_batch(self, robot, names, X) -> tuple[np.ndarray, np.ndarray]:
        """Per displaced robot ``X (P, k)`` the planes fitted to its own faces (:meth:`fit_flush`);
        residuals ``(P, 3N)`` and the coefficients ``(P, 3K)``."""
        T = self.batch_tcp(robot, names, X)
        coef = self.fit_flush(T)
        return -self.modelled(T, coef).reshape(X.shape[0], -1), coef

    def position_errors(self, robot, nuisance) -> np.ndarray:
        """``(N,)`` each contact's error, m: the norm of the face centre's height off its plane and
        the two rim lifts (tilts times ``TILT_LENGTH_M``), what ``evaluate`` reports too."""
        return np.linalg.norm(self.modelled(self._fk(robot), nuisance), axis=1)

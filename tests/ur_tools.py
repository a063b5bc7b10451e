"""Test-side, independent implementations for the UR factory-calibration tests: the controller's
DH forward kinematics, ur_description's xacro composition, a port of the ROS driver's
ur_calibration (buildChain, correctAxis, getSimplified, toYaml with Eigen's eulerAngles(0, 1, 2))
and the conversion of joint lines to a standard DH table (how a near-parallel UR arm gets its
hundreds of metres of d). `python tests/ur_tools.py` writes the test files in tests/data."""

from __future__ import annotations

from pathlib import Path

import numpy as np

DATA = Path(__file__).parent / "data"
LINKS = ("shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3")


def rot(axis: str, t: float) -> np.ndarray:
    c, s = np.cos(t), np.sin(t)
    R = {"x": [[1, 0, 0], [0, c, -s], [0, s, c]], "y": [[c, 0, s], [0, 1, 0], [-s, 0, c]],
         "z": [[c, -s, 0], [s, c, 0], [0, 0, 1]]}[axis]
    T = np.eye(4)
    T[:3, :3] = R
    return T


def trans(x=0.0, y=0.0, z=0.0) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


def dh_fk(theta, d, a, alpha, q) -> np.ndarray:
    """The controller's model: prod_i Rz(theta_i + q_i) Tz(d_i) Tx(a_i) Rx(alpha_i), one pose per row."""
    out = []
    for row in np.atleast_2d(q):
        T = np.eye(4)
        for i in range(6):
            T = T @ rot("z", theta[i] + row[i]) @ trans(z=d[i]) @ trans(x=a[i]) @ rot("x", alpha[i])
        out.append(T)
    return np.array(out)


def urdf_rpy(roll, pitch, yaw) -> np.ndarray:
    """URDF: fixed-axis roll, pitch, yaw = Rz(yaw) Ry(pitch) Rx(roll)."""
    return rot("z", yaw) @ rot("y", pitch) @ rot("x", roll)


def xacro_fk(kinematics: dict, q) -> np.ndarray:
    """ur_description's chain from `base` to `tool0`: base_link -> base_link_inertia Rz(pi), the six
    joints (origin xyz, rpy from the YAML, then Rz(q)), wrist_3 -> flange rpy (0, -pi/2, -pi/2),
    flange -> tool0 rpy (pi/2, 0, pi/2); `base` is base_link Rz(pi)."""
    base_link_to_base = urdf_rpy(0, 0, np.pi)
    tip = urdf_rpy(0, -np.pi / 2, -np.pi / 2) @ urdf_rpy(np.pi / 2, 0, np.pi / 2)
    out = []
    for row in np.atleast_2d(q):
        T = urdf_rpy(0, 0, np.pi)  # base_link -> base_link_inertia
        for i, link in enumerate(LINKS):
            k = kinematics[link]
            origin = trans(k["x"], k["y"], k["z"]) @ urdf_rpy(k["roll"], k["pitch"], k["yaw"])
            T = T @ origin @ rot("z", row[i])
        out.append(np.linalg.inv(base_link_to_base) @ T @ tip)
    return np.array(out)


def eigen_euler_012(R: np.ndarray) -> np.ndarray:
    """Eigen's Matrix3d::eulerAngles(0, 1, 2) (R = Rx(a0) Ry(a1) Rz(a2), a0 in [0, pi])."""
    i, j, k = 0, 1, 2
    res = np.zeros(3)
    res[0] = np.arctan2(R[j, k], R[k, k])
    c2 = np.hypot(R[i, i], R[i, j])
    if res[0] > 0:  # (!odd) && res[0] > 0
        res[0] -= np.pi
        res[1] = np.arctan2(-R[i, k], -c2)
    else:
        res[1] = np.arctan2(-R[i, k], c2)
    s1, c1 = np.sin(res[0]), np.cos(res[0])
    res[2] = np.arctan2(s1 * R[k, i] - c1 * R[j, i], c1 * R[j, j] - s1 * R[k, j])
    return -res


def driver_yaml(theta, d, a, alpha, release: str = "current") -> dict:
    """What ur_calibration writes for the controller's DH table (its algorithm, ported):
    ``release`` "current" (both drivers since "Fix calibration", June 2024: ROS 2 #1017, ROS 1
    #704: new theta = atan2(y, x) - pi) or "atan" (the code before: new theta = atan(y / x),
    which lands half a turn off when the axis crosses the plane at x > 0)."""
    chain = []
    for i in range(6):
        chain.append(rot("z", theta[i]) @ trans(z=d[i]))
        chain.append(trans(x=a[i]) @ rot("x", alpha[i]))
    for link in (1, 2):  # correctAxis(1), correctAxis(2)
        if chain[2 * link][2, 3] == 0.0:
            continue
        passive = chain[2 * link] @ chain[2 * link + 1]
        start, nxt = passive[:3, 3], (passive @ chain[2 * link + 2])[:3, 3]
        direction = (nxt - start) / np.linalg.norm(nxt - start)
        param = -start[2] / direction[2]  # the line through start, nxt meets z = 0
        hit = start + param * direction
        if release == "atan":
            new_theta = np.arctan(hit[1] / hit[0])
        else:
            new_theta = np.arctan2(hit[1], hit[0]) - (np.pi if abs(a[link]) > 0 else 0.0)
        new_length = -np.linalg.norm(hit)
        correction = param * (1.0 if direction[2] > 0 else -1.0)
        chain[2 * link] = rot("z", new_theta)
        chain[2 * link + 1] = trans(x=new_length) @ rot("z", theta[link] - new_theta) @ rot("x", alpha[link])
        chain[2 * link + 2][2, 3] -= correction
    simplified = [chain[0]] + [chain[k] @ chain[k + 1] for k in range(1, 11, 2)]
    out = {}
    for link, T in zip(LINKS, simplified, strict=True):
        r, p, y = eigen_euler_012(T[:3, :3])
        out[link] = {"x": T[0, 3], "y": T[1, 3], "z": T[2, 3], "roll": r, "pitch": p, "yaw": y}
    return out


def lines_to_dh(u, p, flange):
    """Standard DH (theta, d, a, alpha) of joint lines (unit u, points p, world, q = 0) whose
    axis 1 is the world z line, with DH frame 6 = ``flange`` (its z along axis 6): frame i on
    axis i+1 at the common normal with axis i -- far away when the axes are nearly parallel."""
    frames = [np.eye(4)]
    for i in range(1, 6):
        z0, z1, p0, p1 = u[i - 1], u[i], p[i - 1], p[i]
        w = np.cross(z0, z1)
        r = p1 - p0
        foot = p1 + (np.cross(r, z0) @ w) / (w @ w) * z1  # on axis i+1
        x = w / np.linalg.norm(w)
        if x @ frames[-1][:3, 0] < 0:
            x = -x
        T = np.eye(4)
        T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = x, np.cross(z1, x), z1, foot
        frames.append(T)
    frames.append(flange)
    theta, d, a, alpha = (np.zeros(6) for _ in range(4))
    for i in range(6):
        F0, F1 = frames[i], frames[i + 1]
        x0, z0, o0, x1, z1, o1 = F0[:3, 0], F0[:3, 2], F0[:3, 3], F1[:3, 0], F1[:3, 2], F1[:3, 3]
        theta[i] = np.arctan2(np.cross(x0, x1) @ z0, x0 @ x1)
        d[i] = (o1 - o0) @ z0
        a[i] = (o1 - o0) @ x1
        alpha[i] = np.arctan2(np.cross(z0, z1) @ x1, z0 @ z1)
    return theta, d, a, alpha


def true_arm_dh(name: str, seed: int):
    """A realistic factory-calibrated arm of catalog UR ``name`` as the controller's DH table:
    the nominal MDH + beta chain moved by sub-millimetre / sub-milliradian errors, axes 2-4 tilted
    out of parallel by tens of microradians (so d reaches metres to hundreds of metres)."""
    import robocal as rc

    nom = rc.Robot.from_catalog(name)
    rng = np.random.default_rng(seed)
    moved = nom.with_values({
        **{f"a{i}": nom.get(f"a{i}") + rng.normal(0, 2e-4) for i in range(2, 7)},
        **{f"d{i}": nom.get(f"d{i}") + rng.normal(0, 2e-4) for i in (1, 4, 5, 6)},
        **{f"theta{i}": nom.get(f"theta{i}") + rng.normal(0, 5e-4) for i in range(1, 7)},
        **{f"alpha{i}": nom.get(f"alpha{i}") + rng.normal(0, 3e-4) for i in (2, 5, 6)},
        "alpha3": 3e-4, "alpha4": -2e-4, "beta3": 1.2e-3, "beta4": -9e-4})
    q0 = np.zeros((1, 6))
    tcp, frames = moved.fk(q0, frames=True)
    u, p = frames[0, 1:, :3, 2], frames[0, 1:, :3, 3]
    flange = tcp[0]
    return lines_to_dh(u, p, flange)


def write_files() -> None:
    from robocal.kinematics.manufacturer.ur import nominal_dh

    nominal = nominal_dh("ur5e")
    theta, d, a, alpha = true_arm_dh("ur5e", 31)
    deltas = {"delta_theta": (theta - nominal.theta + np.pi) % (2 * np.pi) - np.pi,
              "delta_a": a - nominal.a, "delta_d": d - nominal.d, "delta_alpha": alpha - nominal.alpha}
    lines = ["[mounting]"]
    for key, vals in deltas.items():
        lines.append(f"{key} = [ " + ", ".join(f"{0.0 if abs(v) < 1e-15 else v:.18g}" for v in vals) + "]")
    lines += ["joint_checksum = [ 0x5a1e03c2, 0x9b0f77d1, 0x1c44e2a9, 0x7e6d0b35, 0xc2f9a818, 0x30b7d4e6]",
              "calibration_status = 2 # 0 == notInitialized / 1 == notLinearised / 2 == Linearised",
              "joint_raw_offset = [ 0x31aa98, 0x324a55, 0xd4b163, 0xdd705d, 0xdce343, 0xdce0d7]",
              "joint_selftest_data_crc = [ 0x17c8de80, 0x3ebb8929, 0xb52a8da3, 0xb0085efb, 0xdb6091f6, "
              "0x38388502]",
              ""]
    (DATA / "ur5e_calibration.conf").write_text("\n".join(lines))
    theta, d, a, alpha = true_arm_dh("ur10e", 32)
    kin = driver_yaml(theta, d, a, alpha)
    out = ["kinematics:"]
    for link in LINKS:
        out.append(f"  {link}:")
        out += [f"    {k}: {float(kin[link][k]) + 0.0!r}" for k in ("x", "y", "z", "roll", "pitch", "yaw")]
    out += ["  hash: calib_5287431934982740217", ""]
    (DATA / "ur10e_calibration.yaml").write_text("\n".join(out))


if __name__ == "__main__":
    write_files()

"""Method ``neural`` (seed 002): a BP network from a target's pose error to structural errors.

Network: input x = the measured-minus-modelled error of one target (item) of the start model —
3 position components in mm, plus 3 orientation components (rotation vector, mrad) when the
data are 6-DOF poses (point data have no orientation: 3 inputs). One hidden layer of
``hidden`` (8-10) sigmoid units h = s(W1 x - b1); linear output y = W2 h - b2: the structural
parameter errors of ``outputs`` (default: the link lengths a, d and joint angles theta among
the free parameters), in mm and mrad. Weights and thresholds start uniform in (0, 1) (a401).

Index (a404): E = mean over targets and residual components of |r| ('mae') or r^2 ('mse'),
mm, where r is measured minus the pose of the model compensated with the network's output for
that target (a403: parameters + y(x_t)). Training (a402-a406) is steepest descent on all
weights and thresholds; dE/dy_t is back-propagated from the analytic identification Jacobian
(``problem.jacobian``: d(modelled)/d(parameters)), never by numerical differentiation. Each
epoch re-linearises at the model compensated with the mean output, so the per-target
residual is r_t ~ r_t(mean) - J_t (y_t - mean y). Deviation from the seed, stated: the seed
presents one unused target per update; here one update uses the gradient summed over all
targets (the same index, deterministic, vectorised), with a bold-driver learning rate
(x1.05 after a decrease of E, x0.5 and the step undone after an increase). Training stops when
E <= ``threshold`` ``n_consecutive`` times in a row (a405/a407; status ``threshold``), when E
improved by less than ``ftol`` (relative) over ``patience`` epochs or no step decreases it any
more (``converged``), or after ``epochs`` (``max_iterations``: not a success).

Compensation (claim 10): measured pose error -> network -> parameter errors -> model + errors
(:func:`compensate`). The solver's final state is the start model compensated with the mean of
the network's outputs over the calibration targets. Networks save as ``.npz`` or ``.json``
(plain arrays, never pickle).
"""

from __future__ import annotations

import numpy as np

from robocal.core.damped_least_squares import Status
from robocal.core.errors import IdentificationError
from robocal.data.kinds import OBSERVED
from robocal.identify.network import FIELDS, BPNetwork
from robocal.identify.population import Stagnation
from robocal.identify.solvers import SolverResult, history_entry
from robocal.identify.space import ParameterSpace, State


def pose_error_inputs(problem, state) -> np.ndarray:
    """Network inputs ``(N, 3|6)``: each target's measured-minus-modelled error, mm / mrad."""
    obs = problem.observation
    r = obs.residuals(state.robot, state.nuisance).reshape(obs.n_items, obs.rows_per_item)
    spec = OBSERVED.get(problem.kind)  # None: several kinds ("mixed")
    if spec is None or not spec.sees_position:
        raise IdentificationError("method 'neural' needs point or pose data (its input is a pose error)")
    if spec.sees_orientation:  # orientation rows are scaled by the length scale
        r = r.copy()
        r[:, 3:6] /= obs.scale[3]
    return r[:, :6] * 1e3


def compensate(network: BPNetwork, robot, pose_error_mm) -> object:
    """Claim 10: pose error(s) ``(3|6,)`` or ``(N, 3|6)`` (mm / mrad) -> network -> the
    robot with its structural parameters compensated by the (mean) output."""
    y = network.parameter_errors(pose_error_mm).mean(axis=0)
    return robot.displaced(network.outputs, y)


def default_outputs(names) -> list[str]:
    """Seed 002's structural errors: link lengths (a, d) and joint angles (theta) among names."""
    return [n for n in names if n.rstrip("0123456789") in ("a", "d", "theta")]


MIN_LEARNING_RATE = 1e-14  # below this no steepest-descent step decreases the index: converged


def train(problem, start: State, outputs: list[str], *, hidden: int = 9, index: str = "mae",
          learning_rate: float = 0.01, epochs: int = 3000, threshold: float = 0.0,
          n_consecutive: int = 5, patience: int = 100, ftol: float = 1e-6, seed: int = 0,
          progress=None):
    """Train the network (a401-a407). Returns ``(network, x, history, indices, status)``: the
    inputs ``x (N, 3|6)`` (mm / mrad), the SI history, the index E of every epoch (mm or mm^2)."""
    if not 8 <= hidden <= 10:
        raise IdentificationError(f"hidden must be 8-10 units (seed 002), got {hidden}")
    if index not in ("mae", "mse"):
        raise IdentificationError(f"index must be 'mae' or 'mse', got {index!r}")
    if epochs < 1 or n_consecutive < 1 or not learning_rate > 0:
        raise IdentificationError("epochs and n_consecutive must be >= 1 and learning_rate > 0")
    x = pose_error_inputs(problem, start)
    net = BPNetwork.init(x.shape[1], hidden, outputs, np.random.default_rng(seed))
    rows = problem.observation.rows_per_item
    k = len(outputs)
    space = ParameterSpace(tuple(outputs), tuple(problem.nuisance_names))
    no_nuisance = np.zeros(len(start.nuisance))

    def evaluate(net):
        h, y = net.forward(x)
        ybar = y.mean(axis=0)
        st = space.apply(start, np.concatenate([ybar * 1e-3, no_nuisance]))
        r = problem.residuals(st) * 1e3  # mm
        J = problem.jacobian(st, space)[:, :k].reshape(-1, rows, k)  # d(model)/d(param)
        rt = r.reshape(-1, rows) - np.einsum("nrk,nk->nr", J, y - ybar)  # mm, (y in mm/mrad)
        cost = float(np.mean(np.abs(rt)) if index == "mae" else np.mean(rt**2))
        return cost, h, rt, J

    def entry(epoch: int, rt: np.ndarray) -> dict:  # rt in mm: the history is SI
        return history_entry(epoch, float(np.sum(rt**2)) * 1e-6, len(rt))

    streak, lr = 0, learning_rate
    cost, h, rt, J = evaluate(net)
    history, indices = [entry(0, rt)], [cost]
    stagnation = Stagnation(patience, ftol)
    status = Status.MAX_ITERATIONS
    for epoch in range(1, epochs + 1):
        # dE/dr, then dE/dy_t = -(dE/dr_t) J_t  (r = measured - modelled)
        g_r = (np.sign(rt) if index == "mae" else 2.0 * rt) / rt.size
        g_y = -np.einsum("nr,nrk->nk", g_r, J)
        grads = {"W2": g_y.T @ h, "b2": -g_y.sum(axis=0)}
        g_z = (g_y @ net.W2) * h * (1.0 - h)
        grads["W1"], grads["b1"] = g_z.T @ x, -g_z.sum(axis=0)
        old = {f: getattr(net, f).copy() for f in FIELDS}
        for f in FIELDS:
            setattr(net, f, old[f] - lr * grads[f])
        trial = evaluate(net)
        if trial[0] > cost:  # undo the step, halve the rate
            for f in FIELDS:
                setattr(net, f, old[f])
            lr *= 0.5
        else:
            cost, h, rt, J = trial
            lr *= 1.05
        history.append(entry(epoch, rt))
        indices.append(cost)
        if progress is not None:
            progress(epoch, history[-1]["rms"])
        streak = streak + 1 if cost <= threshold else 0
        if streak >= n_consecutive:
            status = Status.THRESHOLD
            break
        if lr < MIN_LEARNING_RATE or stagnation.update(cost):
            status = Status.CONVERGED
            break
    return net, x, history, indices, status


def solve(problem, start: State, space: ParameterSpace, *, seed: int = 0, progress=None, outputs=None,
          hidden: int = 9, index: str = "mae", learning_rate: float = 0.01, epochs: int = 3000,
          threshold: float = 0.0, n_consecutive: int = 5, patience: int = 100, ftol: float = 1e-6,
          **_) -> SolverResult:
    """Seed-002 network on ``outputs`` (default :func:`default_outputs` of the free robot
    parameters); ``threshold`` in mm (mae) or mm^2 (mse)."""
    names = list(space.robot)
    if outputs is None or outputs == "lengths_angles":
        outputs = default_outputs(names)
    elif outputs == "all":
        outputs = list(names)
    elif isinstance(outputs, str):
        outputs = [o for o in outputs.replace(",", " ").split() if o]
    missing = [o for o in outputs if o not in names]
    if missing or not outputs:
        raise IdentificationError(f"network outputs {missing or outputs} are not free identifiable "
                                  f"parameters; choose from {list(names)}")
    net, x, history, indices, status = train(
        problem, start, list(outputs), hidden=hidden, index=index, learning_rate=learning_rate,
        epochs=epochs, threshold=threshold, n_consecutive=n_consecutive, patience=patience, ftol=ftol,
        seed=seed, progress=progress)
    state = State(compensate(net, start.robot, x), start.nuisance)  # the mean output over the targets
    epochs_run = len(history) - 1
    message = {Status.THRESHOLD: f"index {indices[-1]:.4g} <= threshold {threshold} {n_consecutive} times "
                                 f"in a row after {epochs_run} epochs",
               Status.CONVERGED: f"index {indices[-1]:.4g} stopped decreasing after {epochs_run} epochs",
               Status.MAX_ITERATIONS: f"stopped at the epoch limit {epochs} with index {indices[-1]:.4g} "
                                      "(threshold not met)"}[status]
    return SolverResult(state=state, status=status, message=message, nit=epochs_run, history=history,
                        network=net)

"""Joint conventions of controllers that differ from the catalog's (ROS-Industrial's) joints.

FANUC controllers count J3 from the horizontal, not from the upper arm: the value a FANUC
controller shows, logs and takes in a TP program is ``J3 + J23_FACTOR * J2`` of the catalog's
joints (ROS-Industrial fanuc_driver: ``J3_out = J3_in + J23_factor * J2_in``, J23_factor 1 for its
arms). A joint log from a FANUC controller is read with `fanuc_decoupled` (CLI
``--fanuc-j2j3-coupled``); robocal's ``--fanuc`` campaign programs write `fanuc_coupled`.

See Also
--------
rc.Measurements : Rows whose joints it converts.
rc.filter_program : Filters FANUC programs in the controller's convention.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from robocal.data.measurements import approach_from_order, travel_from_order

J23_FACTOR = 1.0  # FANUC J3 (controller) = J3 (catalog, ROS-I) + J23_FACTOR * J2
COUPLED_OPTION = "--fanuc-j2j3-coupled"  # the command-line option that reads a FANUC joint log


def fanuc_coupled(q: np.ndarray) -> np.ndarray:
    """Catalog joints ``(N, n)`` (n >= 3) -> the FANUC controller's (J3 from the horizontal).

    Parameters
    ----------
    q : ndarray, shape (N, n)
        Joints in the catalog's (ROS-Industrial) convention, rad; not modified.

    Returns
    -------
    ndarray, shape (N, n)
        The same joints as the controller counts them: J3 + ``J23_FACTOR`` * J2, rad.

    Examples
    --------
    >>> import numpy as np
    >>> from robocal.data.joint_conventions import fanuc_coupled, fanuc_decoupled
    >>> q = np.array([[0.0, 0.3, -0.2, 0.0, 0.5, 0.0]])  # rad
    >>> round(float(fanuc_coupled(q)[0, 2]), 6)  # J3 as the controller shows it
    0.1
    >>> bool(np.allclose(fanuc_decoupled(fanuc_coupled(q)), q))  # and back
    True
    """
    out = np.array(q, dtype=float, copy=True)
    out[:, 2] += J23_FACTOR * out[:, 1]
    return out


def fanuc_decoupled(q: np.ndarray) -> np.ndarray:
    """A FANUC controller's joints ``(N, n)`` (J3 from the horizontal) -> the catalog's.

    Parameters
    ----------
    q : ndarray, shape (N, n)
        Joints as a FANUC controller logs them, rad; not modified.

    Returns
    -------
    ndarray, shape (N, n)
        The catalog's joints: J3 - ``J23_FACTOR`` * J2, rad.

    Examples
    --------
    >>> import numpy as np
    >>> from robocal.data.joint_conventions import fanuc_decoupled
    >>> logged = np.array([[0.0, 0.3, 0.1, 0.0, 0.5, 0.0]])  # rad, from the controller
    >>> round(float(fanuc_decoupled(logged)[0, 2]), 6)
    -0.2
    """
    out = np.array(q, dtype=float, copy=True)
    out[:, 2] -= J23_FACTOR * out[:, 1]
    return out


def fanuc_decoupled_data(data):
    """Measurements whose joints are a FANUC controller's -> the same with the catalog's joints
    (the approach directions and travel re-derived from the row order).

    Parameters
    ----------
    data : Measurements
        Rows whose joints are in the FANUC controller's convention (J3 counted from the horizontal).

    Returns
    -------
    Measurements
        The same rows with the catalog's joints; the input is not changed.
    """
    q = fanuc_decoupled(data.joints)
    return replace(data, joints=q, approach=approach_from_order(q, data.pose_id),
                   travel=travel_from_order(q, data.pose_id))

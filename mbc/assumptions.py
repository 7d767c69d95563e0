r"""Model-assumption monitors: how far the robot is from what the ALIP model assumes.

The ALIP model assumes a constant CoM height z = z_bar, with z' = 0 and z'' = 0 (the paper's
Eq. (2)). Each control tick reports those violations, plus monitors of the other modelling
assumptions of the controller: a stance foot that does not slip, small centroidal angular
momentum about the CoM (lumped in the ALIP's L), a solvable QP and unsaturated torques.

`mar_weight` is the paper's model-assumption-based regularization weight,
w(s) = w0 exp(-z'^2 / delta), with w0 = 5 and delta = 0.0159 (m/s)^2.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

MAR_W0 = 5.0
MAR_DELTA = 0.0159


def mar_weight(com_vertical_velocity_mps, w0: float = MAR_W0, delta: float = MAR_DELTA):
    """MAR regularization weight w0 exp(-z'^2 / delta) (broadcasts)."""
    return w0 * np.exp(-np.square(com_vertical_velocity_mps) / delta)


@dataclass(frozen=True)
class AssumptionReport:
    """Per-tick model-assumption violations and solver health."""

    com_height_error_m: float
    """CoM height above the stance sole minus the ALIP z_bar [m]."""
    com_vertical_velocity_mps: float
    """CoM vertical velocity z' [m/s] (ALIP assumes 0)."""
    com_vertical_acceleration_mps2: float
    """CoM vertical acceleration z'' planned by the QP [m/s^2] (ALIP assumes 0)."""
    stance_slip_speed_mps: float
    """Horizontal speed of the stance sole [m/s] (assumed 0)."""
    centroidal_angular_momentum: float
    """|angular momentum about the CoM| [kg m^2/s]."""
    qp_solved: bool
    torque_saturation: float
    """Fraction of joints at their torque limit."""

    NAMES = ("com_height_error_m", "com_vertical_velocity_mps", "com_vertical_acceleration_mps2",
             "stance_slip_speed_mps", "centroidal_angular_momentum", "qp_solved", "torque_saturation")

    @classmethod
    def unavailable(cls) -> AssumptionReport:
        """The report of a tick without a solution: monitors NaN, QP not solved."""
        return cls(np.nan, np.nan, np.nan, np.nan, np.nan, qp_solved=False, torque_saturation=0.0)

    def as_array(self) -> np.ndarray:
        """(7,) the fields in `NAMES` order, as floats."""
        return np.array([float(v) for v in asdict(self).values()])

    @property
    def mar_weight(self) -> float:
        return float(mar_weight(self.com_vertical_velocity_mps))


def saturation(tau: np.ndarray, limit: np.ndarray, tolerance: float = 1e-6) -> float:
    """Fraction of joints whose |torque| is at the limit."""
    return sum(abs(torque) >= bound - tolerance for torque, bound in zip(tau.tolist(), limit.tolist())) / len(tau)

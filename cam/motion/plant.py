"""Two-degree-of-freedom (TDOF) plant of an indexing table and its exact simulation.

Method M5 (seed 000, section II.B): the indexing table is modelled as two masses, the
motor side (rotor, coupling and screw as an equivalent mass) and the table, joined by
a spring and a damper. The paper's own equation of motion (its Eq. (5)) is on a page
missing from the extraction; this module writes the model down explicitly:

    m1 x1'' = kp (r - x1) + kd (r' - x1') + f m_total r'' - k (x1 - x2) - c (x1' - x2')
    m2 x2'' = k (x1 - x2) + c (x1' - x2')

``x1`` motor side, ``x2`` table (mm), ``r`` the commanded profile (mm). The servo is a
position loop with stiffness ``kp`` and damping ``kd`` plus an acceleration
feed-forward fraction ``f`` of the total mass ``m_total = m1 + m2``. State
``s = [x1, x2, x1', x2']``, input ``u = [r, r', r'']``.

Units: masses kg, stiffness N/m, damping N s/m. A force in kg mm/s^2 is k [kg/s^2]
times a length in mm, so N/m and N s/m are used unchanged with mm and s.

Two exact solutions are provided:

* ``simulate``: the sampled-data system (the command held over each controller period
  ``dt``, zero-order hold) through the state transition ``Phi = expm(A dt)`` and
  ``Gamma``, computed once with ``scipy.linalg.expm``, then a numba recursion over many
  input histories at once. Exact for a held input (``scipy.signal.lsim`` computes the
  same thing one history at a time).
* ``residual_modes`` + ``cam.motion.positioning``: the continuous response to an
  S-curve after the end of the move, in closed form from the modal expansion of the
  jerk-step response (used by the optimiser, millions of profiles).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

import numba
import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from cam.motion.schema import PlantFile
from cam.motion.tomlio import read_toml
from impeller_cam.errors import InputError
from impeller_cam.schema import validate

Output = Literal["acceleration", "position"]
OUTPUTS: tuple[str, ...] = ("acceleration", "position")

#: Plant parameter names in TOML order (the ``[plant]`` table).
PARAMETERS: tuple[str, ...] = (
    "motor_mass", "table_mass", "stiffness", "damping",
    "servo_stiffness", "servo_damping", "feedforward",
)


@dataclass(frozen=True)
class TwoMassPlant:
    """Motor side and table joined by a spring and a damper, driven by a PD servo.

    Attributes
    ----------
    motor_mass : float
        Equivalent mass of rotor, coupling and screw, kg (``J (2 pi / lead)^2``).
    table_mass : float
        Table mass, kg.
    stiffness : float
        Spring between motor side and table, N/m.
    damping : float
        Damper between motor side and table, N s/m.
    servo_stiffness : float
        Position-loop stiffness on the motor side, N/m.
    servo_damping : float
        Velocity-loop damping on the motor side, N s/m.
    feedforward : float
        Acceleration feed-forward as a fraction of the total mass (0..1).
    """

    motor_mass: float
    table_mass: float
    stiffness: float
    damping: float
    servo_stiffness: float
    servo_damping: float
    feedforward: float = 1.0

    def with_parameters(self, **values: float) -> TwoMassPlant:
        """A copy with some parameters replaced."""
        return replace(self, **values)

    def state_space(
        self, output: Output = "acceleration"
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
               NDArray[np.float64]]:
        """Continuous state space ``s' = A s + B u``, ``y = C s + D u``.

        Parameters
        ----------
        output : {"acceleration", "position"}
            Table acceleration (mm/s^2) or table position (mm).

        Returns
        -------
        A : (4, 4), B : (4, 3), C : (1, 4), D : (1, 3) float64
        """
        m1, m2 = self.motor_mass, self.table_mass
        k, c = self.stiffness, self.damping
        kp, kd = self.servo_stiffness, self.servo_damping
        a = np.zeros((4, 4))
        a[0, 2] = a[1, 3] = 1.0
        a[2] = [-(kp + k) / m1, k / m1, -(kd + c) / m1, c / m1]
        a[3] = [k / m2, -k / m2, c / m2, -c / m2]
        b = np.zeros((4, 3))
        b[2] = [kp / m1, kd / m1, self.feedforward * (m1 + m2) / m1]
        if output == "acceleration":
            cmat = a[3:4].copy()
        elif output == "position":
            cmat = np.array([[0.0, 1.0, 0.0, 0.0]])
        else:
            raise InputError("unknown output", field="output", value=output,
                             accepted=", ".join(OUTPUTS))
        return a, b, cmat, np.zeros((1, 3))

    def _modes(self) -> NDArray[np.complex128]:
        lam = np.linalg.eigvals(self.state_space()[0])
        lam = lam[lam.imag >= -1e-12 * np.abs(lam)]  # one of each conjugate pair
        return lam[np.argsort(np.abs(lam))]

    def natural_frequencies(self) -> NDArray[np.float64]:
        """Undamped-equivalent frequencies ``|lambda| / 2 pi`` of the modes, Hz, ascending.

        Two values for two underdamped modes (an overdamped mode gives two real
        eigenvalues, each listed).
        """
        return np.abs(self._modes()) / (2 * np.pi)

    def damping_ratios(self) -> NDArray[np.float64]:
        """Damping ratios ``-Re(lambda) / |lambda|``, in the order of the frequencies."""
        lam = self._modes()
        return -lam.real / np.abs(lam)


def discretise(
    plant: TwoMassPlant, dt: float, output: Output = "acceleration"
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
           NDArray[np.float64]]:
    """Zero-order-hold discretisation: ``s[k+1] = Phi s[k] + Gamma u[k]``.

    One ``scipy.linalg.expm`` of the block matrix ``[[A, B], [0, 0]] dt``.

    Returns
    -------
    Phi : (4, 4), Gamma : (4, 3), C : (1, 4), D : (1, 3) float64
    """
    a, b, c, d = plant.state_space(output)
    block = np.zeros((7, 7))
    block[:4, :4] = a * dt
    block[:4, 4:] = b * dt
    expo = scipy.linalg.expm(block)
    return expo[:4, :4].copy(), expo[:4, 4:].copy(), c, d


@numba.njit(cache=True)
def _zoh_recursion(
    phi: NDArray[np.float64],
    gamma: NDArray[np.float64],
    c: NDArray[np.float64],
    d: NDArray[np.float64],
    u: NDArray[np.float64],
    out: NDArray[np.float64],
) -> None:  # pragma: no cover - compiled
    p, n, _ = u.shape
    for i in range(p):
        s0 = s1 = s2 = s3 = 0.0
        for k in range(n):
            u0, u1, u2 = u[i, k, 0], u[i, k, 1], u[i, k, 2]
            out[i, k] = (c[0, 0] * s0 + c[0, 1] * s1 + c[0, 2] * s2 + c[0, 3] * s3
                         + d[0, 0] * u0 + d[0, 1] * u1 + d[0, 2] * u2)
            n0 = (phi[0, 0] * s0 + phi[0, 1] * s1 + phi[0, 2] * s2 + phi[0, 3] * s3
                  + gamma[0, 0] * u0 + gamma[0, 1] * u1 + gamma[0, 2] * u2)
            n1 = (phi[1, 0] * s0 + phi[1, 1] * s1 + phi[1, 2] * s2 + phi[1, 3] * s3
                  + gamma[1, 0] * u0 + gamma[1, 1] * u1 + gamma[1, 2] * u2)
            n2 = (phi[2, 0] * s0 + phi[2, 1] * s1 + phi[2, 2] * s2 + phi[2, 3] * s3
                  + gamma[2, 0] * u0 + gamma[2, 1] * u1 + gamma[2, 2] * u2)
            n3 = (phi[3, 0] * s0 + phi[3, 1] * s1 + phi[3, 2] * s2 + phi[3, 3] * s3
                  + gamma[3, 0] * u0 + gamma[3, 1] * u1 + gamma[3, 2] * u2)
            s0, s1, s2, s3 = n0, n1, n2, n3


def simulate(
    plant: TwoMassPlant,
    command: NDArray[np.float64],
    dt: float,
    output: Output = "acceleration",
) -> NDArray[np.float64]:
    """Exact sampled-data response of the table to held commands, from rest.

    Parameters
    ----------
    plant : TwoMassPlant
    command : (p, n, 3) or (n, 3) float64
        Commanded position (mm), velocity (mm/s) and acceleration (mm/s^2) at the
        sample times ``k dt``; each is held until the next sample.
    dt : float
        Sample (controller) period, s.
    output : {"acceleration", "position"}

    Returns
    -------
    (p, n) or (n,) float64
        Table acceleration (mm/s^2) or position (mm) at the sample times.
    """
    u = np.asarray(command, dtype=np.float64)
    single = u.ndim == 2
    u = np.ascontiguousarray(u.reshape((1,) + u.shape) if single else u)
    if u.ndim != 3 or u.shape[2] != 3:
        raise ValueError(f"command must be (p, n, 3) or (n, 3), not {np.shape(command)}")
    phi, gamma, c, d = discretise(plant, dt, output)
    out = np.empty(u.shape[:2])
    _zoh_recursion(phi, gamma, c, d, u, out)
    return out[0] if single else out


def residual_modes(
    plant: TwoMassPlant, output: Output = "acceleration"
) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """Modes of the response to a unit jerk step, for the closed-form residual.

    The response of ``y`` to a unit jerk step at ``t = 0`` (command
    ``r = t^3/6``) is ``poly(t) - sum_m q_m exp(lambda_m t)``: the polynomial
    particular solution minus the free decay of its initial state.

    Returns
    -------
    rates : (M,) complex128
        Eigenvalues ``lambda_m`` of ``A``, 1/s: one of each complex-conjugate pair
        (positive imaginary part) and the real ones; ``M <= 4``.
    weights : (M,) complex128
        ``q_m = (C V)_m (V^-1 s_p(0))_m`` in output units per (mm/s^3), doubled for
        the kept member of a conjugate pair, so that the real part of the sum over
        the kept modes is the response.
    """
    a, b, c, _ = plant.state_space(output)
    ainv = np.linalg.inv(a)
    a3 = -ainv @ b[:, 0] / 6.0
    a2 = ainv @ (3.0 * a3 - 0.5 * b[:, 1])
    a1 = ainv @ (2.0 * a2 - b[:, 2])
    s_p0 = ainv @ a1
    rates, vectors = np.linalg.eig(a)
    weights = (c[0] @ vectors) * np.linalg.solve(vectors, s_p0.astype(np.complex128))
    # keep one mode of each complex-conjugate pair with twice its weight: the real
    # part of the sum is unchanged and the closed-form search does half the work
    scale = np.abs(rates)
    upper = rates.imag > 1e-12 * scale
    real = np.abs(rates.imag) <= 1e-12 * scale
    keep = upper | real
    factor = np.where(upper, 2.0, 1.0)
    return rates[keep].astype(np.complex128), (weights * factor)[keep].astype(np.complex128)


# --------------------------------------------------------------------------- TOML
def plant_from_dict(data: dict[str, object], file: str | Path | None = None) -> TwoMassPlant:
    """Validate a plant TOML document (``cam.motion.schema.PlantFile``; docs/formats.md)."""
    doc = validate(PlantFile, data, file)
    return TwoMassPlant(**doc.plant.model_dump())


def load_plant(path: str | Path) -> tuple[TwoMassPlant, dict[str, object]]:
    """Read a plant TOML file.

    Returns
    -------
    plant : TwoMassPlant
    document : dict
        The whole parsed document (the optional ``[settling]`` table is read by
        ``cam.motion.positioning.settling_from_dict``).

    Raises
    ------
    InputError
        Missing file, bad TOML, missing or out-of-range parameter.
    """
    path = Path(path)
    data = read_toml(path, "plant")
    return plant_from_dict(data, path), data

"""Energy bookkeeping: E = sum_a m_a c_a T_a against the heat the boundaries supplied.

For the Cleary form V_i g_ij = V_j g_ji, so the exchanges between active particles cancel
in d/dt sum m c T and only ghosts / held particles add heat (``boundary_heat_rate``).  The
ledger adds the input each stepper reports, integrated with the scheme's own quadrature (Heun:
dt/2 (q(T^n) + q(T*)) with the predictor T*; theta method: dt (theta q(T^{n+1}) +
(1 - theta) q(T^n))), so

    residual = E(t) - E(0) - integral of boundary heat                            (3)

is round-off for the Cleary form (and the operator's non-conservation for the corrected
form).  With insulated mirror ghosts on a lattice, or free surfaces, the input is zero
and ``drift`` = (E(t) - E(0)) / |E(0)| itself is round-off.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class EnergyLedger:
    e0: float
    e: float = 0.0
    boundary_input: float = 0.0
    scale: float = 0.0

    def __post_init__(self):
        self.e = self.e0
        self.scale = abs(self.e0)

    def record(self, e_new: float, heat_in: float) -> None:
        """Add one step: the energy after it [J] and the boundary heat it took in [J]
        (the return value of the steppers' ``step``)."""
        self.boundary_input += heat_in
        self.e = e_new
        self.scale = max(self.scale, abs(e_new), abs(self.boundary_input))

    def to_dict(self) -> dict:
        s = self.scale or 1.0
        return {
            "energy_initial_J": self.e0,
            "energy_J": self.e,
            "boundary_heat_input_J": self.boundary_input,
            "energy_drift_rel": (self.e - self.e0) / s,
            "energy_balance_residual_rel": (self.e - self.e0 - self.boundary_input) / s,
        }

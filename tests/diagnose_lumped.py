"""A cheap lumped forward model for the diagnosis' statistics and design logic (NOT imported by
gearfem): two nodes (flank surface s, gear body b) with the same candidate names as the library,
so that :class:`gearfem.diagnose.forward.Surrogate`, the fits, profiles and the experiment design
run on it unchanged, in milliseconds.

    C_s dT_s/dt = P_f - G_t (T_s - T_a) - G_sb (T_s - T_b) - G_r (T_s - T_a)
    C_b dT_b/dt = P_h + G_sb (T_s - T_b) - (G_w + G_bore) (T_b - T_a)

P_f = mu (1 - 0.0) c_f T n: friction power with mu = mu_0 m_f exp(-beta (T_s - 25 C))
(p/p_ref)^e_p (v/v_ref)^e_v and a smooth glass step; P_h = s_hyst c_h T^2 n; G_t, G_w = k_h
(n/1000)^(0.5 + s_h) G_0; G_bore = h_b A_b / (1 + h_b A_b R_hub) (flattens with h_b, the shape
the full model's bore path showed); G_r linearised radiation at T_s; T_a = ambient + dT_amb.
Readings: max_surface = T_s, mean_bulk = T_b, root_mean and camera_max mixes of both, probe:web
near T_b, torque_loss_Nm = (P_f + P_h) / omega. Steady values by fixed-point iteration,
transients by implicit Euler (120 steps).
"""

from __future__ import annotations

import math

import numpy as np

QUANTITIES = (
    "max_surface",
    "mean_bulk",
    "root_mean",
    "camera_max",
    "probe:web",
    "torque_loss_Nm",
)


class LumpedModel:
    """Forward model with the :class:`~gearfem.diagnose.forward.FullModel` interface the
    surrogate and the design need (``evaluate``, ``predict``, ``ambient_C``, ``comm``,
    ``times_s``, ``surrogate_meta``)."""

    def __init__(self, times_s=(), ambient_C: float = 23.0, comm=None) -> None:
        from mpi4py import MPI

        self.times_s = tuple(sorted(set(float(t) for t in times_s)))
        self.ambient_C = float(ambient_C)
        self.comm = comm or MPI.COMM_SELF
        self.solves = 0

    def on(self, comm) -> LumpedModel:
        return LumpedModel(self.times_s, self.ambient_C, comm)

    def cycle(self, torque_Nm: float) -> None:
        """No structural cycle (the FullModel interface the surrogate's MPI split calls)."""

    def surrogate_meta(self) -> dict:
        return {"lumped": 1, "times": self.times_s, "ambient": self.ambient_C}

    def _rates(self, sp, tq, model, Ts):
        g = model.get
        n = sp / 1000.0
        mu = 0.5 * g("friction_scale", 1.0) * math.exp(-g("friction_temperature", 0.0) * (Ts - 25))
        mu *= (math.sqrt(tq / 4.0)) ** g("friction_pressure", 0.0)  # p ~ sqrt(T), 30 MPa at 4 N m
        mu *= (0.25 * n) ** g("friction_sliding_speed", 0.0) if n > 0 else 1.0
        mu_g = g("friction_glass_transition", 0.5)
        mu *= (mu_g + (0.5 - mu_g) / (1.0 + math.exp(-(Ts - 143.0) / 8.0))) / 0.5
        P_f = mu * 0.01 * tq * sp
        P_h = g("hysteresis_scale", 1.0) * 1.5e-5 * tq * tq * sp
        conv = g("convection_scale", 1.0) * n ** (0.5 + g("convection_speed_exponent", 0.0))
        G_t, G_w = 0.5 * conv, 0.3 * conv
        hb = g("bore_heat_path", 0.0) * 2.5e-4
        G_b = hb / (1.0 + hb * 8.0)
        Tk = Ts + 273.15
        G_r = 4 * 5.67e-8 * 0.9 * 0.004 * Tk**3
        return P_f, P_h, G_t + G_r, 1.0, G_w + G_b

    def _steady(self, sp, tq, Ta, model):
        Ts = Ta + 50.0
        for _ in range(200):
            P_f, P_h, Gs, Gsb, Gb = self._rates(sp, tq, model, Ts)
            A = np.array([[Gs + Gsb, -Gsb], [-Gsb, Gsb + Gb]])
            th = np.linalg.solve(A, [P_f, P_h])
            new = Ta + th[0]
            if abs(new - Ts) < 1e-10:
                break
            Ts = 0.5 * Ts + 0.5 * new
        return Ta + th[0], Ta + th[1], P_f + P_h

    def _transient(self, sp, tq, Ta, model):
        Cs, Cb = 30.0, 120.0
        out = {}
        if not self.times_s:
            return out
        Ts, Tb, t = Ta, Ta, 0.0
        dt = self.times_s[-1] / 120.0
        targets = list(self.times_s)
        while targets:
            P_f, P_h, Gs, Gsb, Gb = self._rates(sp, tq, model, Ts)
            A = np.array([[Cs / dt + Gs + Gsb, -Gsb], [-Gsb, Cb / dt + Gsb + Gb]])
            b = [Cs / dt * (Ts - Ta) + P_f, Cb / dt * (Tb - Ta) + P_h]
            th = np.linalg.solve(A, b)
            Ts, Tb, t = Ta + th[0], Ta + th[1], t + dt
            while targets and t >= targets[0] - 1e-9:
                out[targets.pop(0)] = (Ts, Tb, P_f + P_h)
        return out

    @staticmethod
    def _read(sp, Ts, Tb, P):
        return {
            "max_surface": Ts,
            "mean_bulk": Tb,
            "root_mean": 0.4 * Ts + 0.6 * Tb,
            "camera_max": 0.8 * Ts + 0.2 * Tb,
            "probe:web": 0.1 * Ts + 0.9 * Tb,
            "torque_loss_Nm": P / (sp * 2 * math.pi / 60.0),
        }

    def evaluate(self, speed_rpm, torque_Nm, ambient_C, model=None):
        model = dict(model or {})
        self.solves += 1
        Ta = ambient_C + model.get("ambient_offset", 0.0)
        res = {}
        for q, v in self._read(speed_rpm, *self._steady(speed_rpm, torque_Nm, Ta, model)).items():
            res[(q, None)] = v
        for t, st in self._transient(speed_rpm, torque_Nm, Ta, model).items():
            for q, v in self._read(speed_rpm, *st).items():
                res[(q, t)] = v
        return res

    def predict(self, data, model=None):
        cache = {}
        out = []
        for m in data.measurements:
            if m.point not in cache:
                cache[m.point] = self.evaluate(*m.point, model)
            out.append(cache[m.point][(m.quantity, m.time_s)])
        return np.array(out)

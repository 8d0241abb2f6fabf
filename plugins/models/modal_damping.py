"""Damping in the modal domain: each model mode damped as its measured partner decays.

A time-domain least-squares fit of a damping ratio trades damping for amplitude: a mode the model
over-predicts (a shape or force point it cannot match) loses energy fastest with more damping, so
the fit damps it beyond its measured decay. ``measured-modal-damping`` takes the damping ratios
from the records instead: the modes ``odsuite modes`` identifies from each record's hammer FRF
(its usable band, stable poles: the half-power width of each peak), paired by frequency with the
model's modes, averaged over the records. Any structure that sets its modal damping mode by mode
(``damped_modes_hz`` and ``with_mode_damping`` of the structure contract) can use it.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence

import numpy as np

from odsuite.contracts.effects import Effect, Parameter
from odsuite.api import ConfigError
from odsuite.api import Model

#: modes whose damping is taken from the records: a hammer test's band rarely holds more
MAX_MODES = 8
#: a measured mode's half-power band must span this many FRF lines: on fewer (a short record) the
#: peak's width is the record's resolution, not the mode's damping
MIN_LINES_PER_BANDWIDTH = 2.0


class MeasuredModalDamping(Effect):
    name = "measured-modal-damping"
    target = "model"
    description = ("Each mode's damping ratio from the records' identified modes (half-power width in the "
                   "modal domain), not traded for amplitude by the time-domain fit.")

    def __init__(self) -> None:
        self._identified: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}

    def _modes(self, model: Model) -> np.ndarray:
        return np.asarray(model.structure.damped_modes_hz(), float)[:MAX_MODES]

    def parameters(self, model):
        f = self._modes(model)
        if f.size == 0:
            return []
        modes = model.modes()
        current = [float(modes.damping_ratio[np.argmin(np.abs(modes.frequency_hz - fk))]) for fk in f]
        return [Parameter(f"zeta_{k + 1}", "1", min(max(z, 1e-5), 0.5), 1e-5, 0.5,
                          description=f"damping ratio of the model's mode {k + 1} ({fk:.1f} Hz at the start)")
                for k, (fk, z) in enumerate(zip(f, current))]

    def linear_parameters(self, model) -> list[str]:
        return [p.name for p in self.parameters(model)]

    def _apply(self, model, v):
        n = self._modes(model).size
        return model.replace(structure=model.structure.with_mode_damping({k: v[f"zeta_{k + 1}"] for k in range(n)}))

    def measured_modes(self, e) -> tuple[np.ndarray, np.ndarray]:
        """Frequencies (Hz) and damping ratios of the modes identified from a prepared record's
        hammer FRF (every sensor), those too narrow for its resolution left out; cached per record."""
        from odsuite.api import estimate_frf, frf_modes

        key = (e.name, e.n_samples, hashlib.sha1(np.ascontiguousarray(e.measured).tobytes()).hexdigest())
        if key not in self._identified:
            force = e.force if e.force.ndim == 1 else e.force[:, 0]
            try:
                res = frf_modes(estimate_frf([force], [e.measured], e.fs))
                f, z = np.asarray(res.frequency_hz, float), np.asarray(res.damping_ratio, float)
            except (ConfigError, np.linalg.LinAlgError, ValueError):  # too short or too quiet to identify
                f, z = np.zeros(0), np.zeros(0)
            resolved = 2 * z * f >= MIN_LINES_PER_BANDWIDTH * e.fs / e.n_samples
            self._identified[key] = (f[resolved], z[resolved])
        return self._identified[key]

    def project(self, models: Mapping[str, Model], values: Mapping[str, float], exps: Sequence,
                base: Sequence[np.ndarray], weights: Sequence[np.ndarray] | None
                ) -> tuple[dict[str, float], dict[str, dict[str, float]], list[np.ndarray]]:
        """The damping ratios of the measured partners (mean over the records), each model mode
        without one keeping its own; ``weights`` do not apply (nothing is fitted here)."""
        from odsuite.api import PAIR_TOLERANCE, pair_modes, predict

        first = next(iter(models.values()))
        f_model = self._modes(first)
        nominal = {p.name: p.nominal for p in self.parameters(first)}
        found: dict[int, list[float]] = {}
        for e in exps:
            f, z = self.measured_modes(e)
            if not f.size:
                continue
            for p in pair_modes(f, z, f_model, np.zeros_like(f_model)):
                if abs(p["frequency_difference"]) <= PAIR_TOLERANCE:
                    found.setdefault(p["mode_b"], []).append(p["damping_a"])
        shared = {f"zeta_{k + 1}": float(np.mean(found[k])) if k in found else nominal[f"zeta_{k + 1}"]
                  for k in range(f_model.size)}
        deltas = [predict(self.apply(models[e.name], shared), e) - b for e, b in zip(exps, base)]
        return shared, {}, deltas


def modal_damping_effects() -> list[Effect]:
    return [MeasuredModalDamping()]

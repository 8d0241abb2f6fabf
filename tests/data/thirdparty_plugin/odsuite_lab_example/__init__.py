"""A lab's own odsuite plugin: registers a physical effect and a renderer without touching odsuite."""

from odsuite import hookimpl


class ThermalDrift:
    """Adds a slow linear drift to a predicted signal (a made-up lab effect)."""

    name = "lab_thermal_drift"

    def apply_to_signal(self, signal, slope_per_sample):
        import numpy as np

        return np.asarray(signal, dtype=float) + slope_per_sample * np.arange(len(signal))


class AsciiRenderer:
    name = "lab_ascii"

    def render(self, values):
        return "".join("#" if v > 0 else "." for v in values)


@hookimpl
def odsuite_register_effects(registry):
    registry.add("lab_thermal_drift", ThermalDrift())


@hookimpl
def odsuite_register_renderers(registry):
    registry.add("lab_ascii", AsciiRenderer())

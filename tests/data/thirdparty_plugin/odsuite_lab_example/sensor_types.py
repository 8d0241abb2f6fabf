"""The lab's accelerometers as their datasheets state them: sensitivity in mV/g."""

from odsuite.api import ConfigError
from odsuite.api import single_axis_sensor

#: standard gravity, m/s^2 (ISO 80000-3): the g of every accelerometer datasheet
G = 9.80665


class DatasheetAccelerometer:
    name = "lab_mv_per_g"
    description = "a single-axis accelerometer whose 'sensitivity' is in mV/g, as on its datasheet"
    quantity = "acceleration"
    unit = "m/s^2"

    def sensors(self, entry, where):
        mv_per_g = entry.get("sensitivity")
        if isinstance(mv_per_g, bool) or not isinstance(mv_per_g, (int, float)) or not mv_per_g > 0:
            raise ConfigError(f"{where} field 'sensitivity': expected mV/g > 0, got {mv_per_g!r}")
        return [single_axis_sensor(entry, where, kind="accelerometer", quantity=self.quantity,
                                   sensitivity=mv_per_g / 1000.0 / G)]

"""The generalized coordinates of an experiment as a CSV table, for the lab's spreadsheet."""

import csv

from odsuite.api import open_project
from odsuite.api import ConfigError
from odsuite.contracts.renderers import Rendered

COORDS = ("x_m", "y_m", "z_m", "theta_rad", "phi_rad", "psi_rad")


class CoordinatesCsv:
    name = "lab_csv"
    description = "generalized coordinates at each body's centre of mass as CSV (time in s, m, rad)"
    kind = "figure"
    suffixes = (".csv",)

    def render(self, request):
        request.unknown_options(set(), self.name)
        with open_project(request.project) as project:
            if "gencoords" not in project.derived_kinds(request.experiment):
                raise ConfigError(f"{project.path}: experiment {request.experiment!r} has no generalized "
                                  "coordinates; run `odsuite process` first")
            coords = {k.removesuffix("_at_g"): v for k, v in project.read_derived(request.experiment,
                                                                                   "gencoords").items()
                      if k.endswith("_at_g")}
            fs = project.experiment(request.experiment).sampling_rate
        bodies = sorted(coords)
        n = len(next(iter(coords.values())))
        with open(request.output, "w", newline="") as f:
            out = csv.writer(f)
            out.writerow(["t_s"] + [f"{b}_{c}" for b in bodies for c in COORDS])
            for i in range(n):
                out.writerow([f"{i / fs:.9g}"] + [f"{coords[b][i, j]:.9g}" for b in bodies for j in range(6)])
        return Rendered(request.output, f"{n} samples of {', '.join(bodies)} as CSV")

"""Coverage of the uncertainties odsuite prints: a known stiffness or mass change hidden in the
independent generator's records, fitted with `odsuite add-effect`, and every physical quantity it
stores (N/m, kg, mm) compared with the simulated rig's value in its own uncertainty.

    python -m tests.independent.coverage --out DIR [--n N] [--rigs thesis,two-body] [--tag TAG]

Each case's processed project is kept in DIR/cases/<id>/ and reused; each run fits a fresh copy
and writes DIR/<tag>/<id>.json and DIR/<tag>/summary.json: per unit the number of quantities, the
rms z-score, the fractions within 1 and 2 sigma (with the 2-sigma fraction's 95 % Clopper-Pearson
interval) and the largest |z|. Only determined quantities are compared: what a row of the effect's
``physical`` names (a spring's effective stiffness along a rig axis, a body's mass, its centre of
mass), and only rows whose nominal value the rig file holds as the generator does.
"""

from __future__ import annotations

import argparse
import json
import shutil
import time
from pathlib import Path

import numpy as np

from . import calibrate, writers

#: hidden change -> the library effect that represents it exactly, the first that applies to the rig:
#: one spring softer on every axis (a spring of its own; where the rig file groups no springs,
#: stiffness is per spring already), one spring group along one axis (one group: the thesis rig's
#: springs), a point mass on a body
CASES = {"softer-mount": ("spring_stiffness", "stiffness"), "softer-axis": ("stiffness",),
         "added-mass": ("mass_properties",)}
#: a group-and-axis change is one product of the stiffness effect only where the rig has one group
RIG_CASES = {"thesis": ("softer-mount", "softer-axis", "added-mass"), "two-body": ("softer-mount", "added-mass"),
             "cabinet": ("softer-mount", "added-mass"), "skid": ("softer-mount", "added-mass")}
FORCES = (5.0, 30.0, 200.0)  # N
NOISES = ({}, {"noise_fraction": 0.01}, {"noise_fraction": 0.03})
AXES = "xyz"


def specs(n: int, rigs) -> list[dict]:
    out = []
    for rig in rigs:
        for case in RIG_CASES[rig]:
            for seed in range(n):
                out.append({"set": "coverage", "rig": rig, "case": case, "seed": seed,
                            "force_n": FORCES[seed % len(FORCES)], **NOISES[(seed // len(FORCES) + seed) % len(NOISES)],
                            "id": f"{rig}-{case}-s{seed}"})
    return out


def truth_of(label: str, rig) -> float | None:
    """The simulated rig's value of a physical row, by its label (None: not one compared here)."""
    st = rig.structure
    if label.startswith("stiffness of "):
        who, axis = label[len("stiffness of "):].rsplit(" along ", 1)
        name = who.split("e.g. ", 1)[1].rstrip(")") if "e.g. " in who else who
        spring = next((s for s in st.springs if s.name == name), None)
        if spring is None:
            return None
        k = np.asarray(spring.stiffness, float)
        return float(np.diag(k)[AXES.index(axis)] if k.ndim == 2 else k[AXES.index(axis)])
    if label.startswith("mass of "):
        return float(st.body(label[len("mass of "):]).mass)
    if label.startswith("centre of mass of "):
        body, axis = label[len("centre of mass of "):].rsplit(", ", 1)
        return 1e3 * float(np.asarray(st.body(body).com, float)[AXES.index(axis)])
    return None


def prepared(spec: dict, out: Path):
    """The case and its processed project (made once)."""
    folder = out / "cases" / spec["id"]
    folder.mkdir(parents=True, exist_ok=True)
    case = calibrate.build(spec)
    project = folder / "base.h5"
    if not project.exists():
        records = case.simulate()
        rig_toml = writers.write_rig_toml(folder / f"{spec['id']}-rig.toml", case.nominal)
        lvms = [writers.write_lvm(folder / f"{spec['id']}-r{i:02d}.lvm", calibrate.without_unused(r))
                for i, r in enumerate(records)]
        truth = writers.to_jsonable(case.truth_document())
        made = calibrate.make_project(folder, rig_toml, lvms, truth)
        made.rename(project)
    return case, project


def run_one(spec: dict, out: Path, tag: str) -> dict:
    t0 = time.time()
    case, project = prepared(spec, out)
    fitted = project.with_name(f"{tag}.h5")
    shutil.copyfile(project, fitted)
    for effect in CASES[spec["case"]]:
        try:
            stored = json.loads(calibrate.odsuite("add-effect", fitted, effect, "--json"))
            break
        except RuntimeError as exc:
            if "does not apply" not in str(exc) or effect == CASES[spec["case"]][-1]:
                raise
    fitted.unlink()
    rows = []
    for entry in stored["effects"]:
        for r in entry.get("physical", []):
            true, nominal = truth_of(r["label"], case.actual), truth_of(r["label"], case.nominal)
            sd = r.get("uncertainty")
            if true is None or not sd or r.get("nominal") is None:
                continue
            if abs(r["nominal"] - nominal) > 1e-6 * max(abs(nominal), 1.0):
                continue  # the rig file holds another value than the generator: not comparable
            rows.append({"label": r["label"], "unit": r["unit"], "value": r["value"], "sd": sd, "true": true,
                         "z": (r["value"] - true) / sd})
    return {**spec, "effect": effect, "truth": writers.to_jsonable(case.truth.get("effect")), "rows": rows,
            "seconds": round(time.time() - t0, 1)}


def summary(results: list[dict]) -> dict:
    out = {}
    units = sorted({r["unit"] for res in results for r in res["rows"]})
    for unit in units + ["all"]:
        z = np.array([r["z"] for res in results for r in res["rows"] if unit in ("all", r["unit"])])
        if not z.size:
            continue
        within2 = int(np.sum(np.abs(z) <= 2))
        out[unit] = {"n": int(z.size), "rms_z": float(np.sqrt(np.mean(z**2))),
                     "within_1": float(np.mean(np.abs(z) <= 1)), "within_2": within2 / z.size,
                     "within_2_interval_95": list(calibrate.clopper_pearson(within2, int(z.size))),
                     "largest": float(np.abs(z).max())}
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tests.independent.coverage", description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--n", type=int, default=3, help="seeds per rig and case")
    parser.add_argument("--rigs", default="thesis,two-body")
    parser.add_argument("--tag", default="run", help="the run's name: its results go to OUT/TAG")
    args = parser.parse_args(argv)
    results = []
    (args.out / args.tag).mkdir(parents=True, exist_ok=True)
    for spec in specs(args.n, args.rigs.split(",")):
        path = args.out / args.tag / f"{spec['id']}.json"
        if path.exists():
            results.append(json.loads(path.read_text()))
            continue
        try:
            res = run_one(spec, args.out, args.tag)
        except Exception as exc:  # a failure is a result, reported with its case
            res = {**spec, "rows": [], "error": f"{type(exc).__name__}: {exc}"}
        path.write_text(json.dumps(res, indent=1))
        results.append(res)
        worst = max((abs(r["z"]) for r in res["rows"]), default=float("nan"))
        print(f"{spec['id']:32s} {len(res['rows']):3d} rows, largest |z| {worst:5.2f}  {res.get('error', '')}"
              f" ({res.get('seconds', 0):.0f} s)", flush=True)
    s = summary(results)
    (args.out / args.tag / "summary.json").write_text(json.dumps(s, indent=1))
    for unit, v in s.items():
        lo, hi = v["within_2_interval_95"]
        print(f"{unit:8s} N {v['n']:4d}  rms z {v['rms_z']:5.2f}  within 1 sigma {100 * v['within_1']:5.1f} %  "
              f"within 2 sigma {100 * v['within_2']:5.1f} % (95 % {100 * lo:.0f}-{100 * hi:.0f} %)  "
              f"largest {v['largest']:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

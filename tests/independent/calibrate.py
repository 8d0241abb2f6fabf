"""Calibration of odsuite's verdict on the independent generator's cases, through the command line
only: for each case a project is made from the case's rig file, its LabVIEW records are imported
(`odsuite import`), processed and diagnosed (`odsuite diagnose --json`).

    python -m tests.independent.calibrate --out DIR --set nulls|faults|pairs|fixed|outside [--n N] [--workers W]
        [--rigs thesis,two-body,plate-motor]

- nulls: no hidden change (several rigs, noise levels, drift, hum, double hits, force levels):
  verdict counts and how many have any significant candidate (the false-alarm rate, with its
  95 % Clopper-Pearson interval);
- faults: a softer mount or an added mass at 5-200 N on the three rigs: the largest
  band-residual-to-noise ratio computed from the truth (truthbands.py), whether the true effect
  is named (the top candidate, significant) and the verdict;
- pairs: two hidden changes at once: the loop (diagnose, add-effect the top significant
  candidate, up to three rounds), the error after it against the floor and what was added;
- fixed: a fault diagnosed on the nominal rig, then again on a project whose model is the truth
  (a rig file with the simulated rig's values): any significant candidate there is a false alarm;
- outside: physics the library has no effect for (Coulomb friction, a rattling stop): the verdict
  must never be "explained".

Every case's result goes to DIR/results/<id>.json as soon as it is done (a rerun skips them);
DIR/<set>.json holds the summary, and a table is printed.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

from . import cases, truthbands, writers

#: the rigs the sets cycle through by default (`--rigs` picks others from rigs.RIGS, e.g. cabinet)
RIGS = ("thesis", "two-body", "plate-motor")
FORCES = (5.0, 10.0, 30.0, 100.0, 200.0)  # N
#: samples per record: enough for each rig's response to fade (thesis: 0.1 s at 20 kHz; two-body
#: 0.2 s at 10.24 kHz, its isolators' 11 Hz for two periods; plate-motor 0.4 s at 5120 Hz), short enough
#: for two shared cores
SAMPLES = {"thesis": 2048, "two-body": 2048, "plate-motor": 2048,
           "cabinet": 2048,  # 0.68 s at 3000 Hz: three periods of its 4.6 Hz rocking
           "skid": 2048,  # 1.0 s at 2048 Hz: six periods of its 6.1 Hz mode
           "gearbox": 2048}  # 0.16 s at 12800 Hz: its slowest mode (208 Hz, 2.4 %) decays to 1.2 % after the blow
#: the chain a lab gives records without a .CTR when the rig's lowest mode is below 20 Hz (the
#: two-body rig's isolators ring at 11 Hz): a 4 Hz high-pass instead of the default 20 Hz
TWO_BODY_PROCESSING = {"offset_samples": [0, 256],
                       "filter": {"family": "butterworth", "type": "highpass", "order": 4, "cutoff_hz": 4.0},
                       "filter_at": ["signal", "integral"]}
#: the library's effects that explain each hidden change
RIGHT = {"stiffness": {"stiffness"}, "added_mass": {"mass_properties"}, "moved_com": {"mass_properties"},
         "sensor_gain": {"sensor_gain"}, "polarity_flip": {"sensor_polarity"}, "channel_delay": {"channel_delay"},
         "sensor_tilt": {"sensor_orientation"}, "channel_swap": {"channel_swap"}, "scan_skew": {"scan_skew"},
         "flexible_mode": {"missing_mode", "coupled_mode", "plate_flexibility", "plate_flexibility_free"}}
NULL_CONDITIONS = [
    {"noise_v": 50e-6},
    {"noise_fraction": 0.01},
    {"noise_fraction": 0.03},
    {"disturbances": ["drift"]},
    {"disturbances": ["hum"]},
    {"disturbances": ["double-hit"]},
    {"noise_fraction": 0.03, "disturbances": ["drift"]},
    {"noise_v": 500e-6, "disturbances": ["hum", "drift"]},
]


def specs(which: str, n: int | None, rigs: tuple[str, ...] = RIGS) -> list[dict]:
    """The cases of a set, deterministic: rig, case, seed, force and noise options. ``rigs``: the
    rigs cycled through (the default three give the cases as they always were)."""
    out = []
    r = len(rigs)
    if which == "nulls":
        for i in range(n or 40):
            rig, cond = rigs[i % r], NULL_CONDITIONS[(i // r) % len(NULL_CONDITIONS)]
            out.append({"case": "null", "rig": rig, "seed": 100 + i, "force_n": FORCES[i % 5], **cond})
    elif which == "faults":
        for i in range(n or 20):
            kind, rig = ("softer-mount", "added-mass")[i % 2], rigs[(i // 2) % r]
            out.append({"case": kind, "rig": rig, "seed": 200 + i, "force_n": FORCES[(i + i // 6) % 5]})
    elif which == "pairs":
        rows = [("pair-gain-com", "thesis"), ("pair-bending-stiffer", "thesis"), ("pair-mount-gain", "plate-motor"),
                ("pair-gain-com", "plate-motor"), ("pair-bending-stiffer", "two-body"), ("pair-mount-gain", "two-body"),
                # measurement effects two at once (their corrections undo both)
                ("polarity-flip+channel-delay", "thesis"), ("sensor-gain+sensor-tilt", "thesis"),
                ("channel-swap+polarity-flip", "thesis"), ("polarity-flip+channel-delay", "two-body"),
                ("sensor-gain+sensor-tilt", "plate-motor"), ("channel-swap+polarity-flip", "two-body")]
        for i in range(n or 3):
            kind, rig = rows[i % len(rows)]
            rig = rig if rigs == RIGS else rigs[i % r]  # other rigs: the same kinds, cycled over them
            out.append({"case": kind, "rig": rig, "seed": 300 + i})
    elif which == "fixed":
        rows = [("softer-mount", "plate-motor", 10.0), ("added-mass", "two-body", 100.0),
                ("softer-mount", "thesis", 30.0), ("added-mass", "plate-motor", 200.0),
                ("softer-mount", "two-body", 30.0), ("added-mass", "thesis", 10.0)]
        for i in range(n or 4):
            kind, rig, force = rows[i % len(rows)]
            rig = rig if rigs == RIGS else rigs[i % r]
            out.append({"case": kind, "rig": rig, "seed": 400 + i, "force_n": force})
    elif which == "outside":
        for i in range(n or 4):
            kind, rig = ("coulomb-friction", "rattle")[i % 2], rigs[(i // 2) % r]
            out.append({"case": kind, "rig": rig, "seed": 500 + i, "force_n": FORCES[(2 + i) % 5]})
    else:
        raise KeyError(which)
    for s in out:
        s["set"] = which
        s["id"] = "-".join([which, s["rig"], s["case"], f"s{s['seed']}"])
    return out


def _odsuite() -> list[str]:
    exe = Path(sys.executable).with_name("odsuite")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "odsuite.cli"]


def odsuite(*args, timeout: float = 1800) -> str:
    proc = subprocess.run(_odsuite() + [str(a) for a in args], capture_output=True, text=True, timeout=timeout,
                          env=os.environ | {"COLUMNS": "200"})
    if proc.returncode != 0:
        raise RuntimeError(f"odsuite {' '.join(map(str, args[:2]))} exited {proc.returncode}: "
                           f"{proc.stderr.strip()[-600:]}")
    return proc.stdout


def build(spec: dict) -> cases.Case:
    case = cases.build_case(spec["case"], spec["seed"], spec["rig"], SAMPLES[spec["rig"]],
                            force_n=spec.get("force_n"), noise_v=spec.get("noise_v"),
                            noise_fraction=spec.get("noise_fraction", 0.0),
                            disturbances=spec.get("disturbances", ()), pre_trigger=spec.get("pre_trigger"))
    if spec["rig"] == "two-body":
        case.nominal.processing = TWO_BODY_PROCESSING
        case.actual.processing = TWO_BODY_PROCESSING
    return case


def true_rig(case: cases.Case) -> cases.RigBundle:
    """The simulated rig as a rig file can hold it: its structure, and every sensor's true
    sensitivity (gain errors folded in)."""
    rig = case.actual.copy()
    for a in rig.accelerometers:
        a.sensitivity *= 1 + a.gain_error
        a.gain_error = 0.0
    return rig


def without_unused(record):
    """The record without the channels no sensor has (the thesis rig's channel 1): a lab's LabVIEW
    file holds the sensors' columns only."""
    from dataclasses import replace

    keep = [k for k, name in enumerate(record.names) if not name.startswith("aux")]
    return replace(record, volts=record.volts[:, keep], clean_volts=record.clean_volts[:, keep],
                   names=[record.names[k] for k in keep], units=[record.units[k] for k in keep],
                   scale=record.scale[keep])


def make_project(folder: Path, rig_toml: Path, lvms: list[Path], truth: dict) -> Path:
    project = folder / f"{rig_toml.stem}.h5"
    if project.exists():
        project.unlink()
    odsuite("new", project, "--rig", rig_toml)
    for i, (lvm, hits) in enumerate(zip(lvms, truth["records"])):
        hit = hits[0]
        point = ",".join(f"{1e3 * v!r}" for v in hit["point_m"])  # mm at the command line
        direction = ",".join(f"{v!r}" for v in hit["direction"])
        odsuite("import", project, lvm, "--name", f"r{i}", f"--force-point={point}", f"--force-dir={direction}",
                "--force-body", hit["body"])
    odsuite("process", project)
    return project


def diagnosis(project: Path) -> dict:
    d = json.loads(odsuite("diagnose", project, "--json", "--workers", "1"))
    cands = d.get("candidates", [])
    top = cands[0] if cands else {}
    return {
        "verdict": d.get("verdict"), "error": d.get("baseline_error"), "floor": d.get("noise_floor_error"),
        "error_to_floor": d["baseline_error"] / d["noise_floor_error"] if d.get("noise_floor_error") else None,
        "significant": [c["effect"] for c in cands if c.get("significant")],
        "top": {"effect": top.get("effect"), "significant": top.get("significant"),
                "validated_error": top.get("validated_error"), "confounded_with": top.get("confounded_with", []),
                "parameters": top.get("parameters", {})},
        "message": d.get("message"), "model_evaluations": d.get("model_evaluations"),
        "cells": (d.get("signature") or {}).get("cells", []),
    }


def covers(truth_kinds: list[str], effects: list[str]) -> bool:
    """Every hidden change is explained by one of ``effects`` (pairs "A+B" count as both)."""
    names = {part for e in effects for part in e.split("+")}
    return all(RIGHT.get(k, set()) & names for k in truth_kinds)


def named(truth_kinds: list[str], diag: dict) -> bool:
    """The top candidate is significant and is (or names as confounded) an effect that explains one
    of the hidden changes."""
    top = diag["top"]
    if not top.get("significant"):
        return False
    right = set().union(*(RIGHT.get(k, set()) for k in truth_kinds))
    return bool((set(top["effect"].split("+")) | set(top.get("confounded_with") or [])) & right)


def project_of(spec: dict, folder: Path) -> Path:
    """The case of ``spec`` simulated and imported into a project in ``folder`` (its rig file and
    records beside it), without its diagnosis: for tests that read the floor or the colour alone."""
    case = build(spec)
    records = case.simulate()
    rig_toml = writers.write_rig_toml(folder / "rig.toml", case.nominal)
    lvms = [writers.write_lvm(folder / f"r{i:02d}.lvm", without_unused(r)) for i, r in enumerate(records)]
    return make_project(folder, rig_toml, lvms, writers.to_jsonable(case.truth_document()))


def run_one(spec: dict, out: Path) -> dict:
    t0 = time.time()
    folder = out / "cases" / spec["id"]
    folder.mkdir(parents=True, exist_ok=True)
    case = build(spec)
    records = case.simulate()
    bands = truthbands.band_residual_to_noise(case, records)
    stem = spec["id"]
    rig_toml = writers.write_rig_toml(folder / f"{stem}-rig.toml", case.nominal)
    lvms = [writers.write_lvm(folder / f"{stem}-r{i:02d}.lvm", without_unused(rec)) for i, rec in enumerate(records)]
    truth = writers.to_jsonable(case.truth_document())
    writers.write_truth(folder / f"{stem}-truth.json", truth | {"band_residual_to_noise": bands})
    kinds = [e["kind"] for e in truth["effects"]] if "effects" in truth else [truth["effect"]["kind"]]
    truth.setdefault("effect", {"kind": "pair", "kinds": kinds})  # names joined by "+" list only their effects
    clipped = [rec.names[k] for rec in records for k in range(rec.volts.shape[1])
               if np.abs(rec.clean_volts[:, k]).max() >= case.actual.daq.adc_range[1]]
    result = {**spec, "truth": truth["effect"] | ({"effects": truth["effects"]} if "effects" in truth else {}),
              "kinds": kinds, "band_ratio": bands["max_ratio"], "band_at": [bands["channel"], bands["band_hz"]],
              "peak_force_n": [float(r.force_n.max()) for r in records], "clipped": sorted(set(clipped))}
    try:
        project = make_project(folder, rig_toml, lvms, truth)
        first = diagnosis(project)
        result["diagnosis"] = first
        result["named"] = named(kinds, first)
        if spec["set"] == "pairs":
            rounds, diag = [], first
            for _ in range(3):
                if not diag["top"].get("significant"):
                    break
                odsuite("add-effect", project, diag["top"]["effect"], "--json")
                rounds.append(diag["top"]["effect"])
                diag = diagnosis(project)
            result["added"] = rounds
            result["final"] = diag
        if spec["set"] == "fixed":
            fixed_toml = writers.write_rig_toml(folder / f"{stem}-true-rig.toml", true_rig(case))
            result["after_fix"] = diagnosis(make_project(folder, fixed_toml, lvms, truth))
    except Exception as exc:  # a failure is a result: reported with its case and seed
        result["error"] = f"{type(exc).__name__}: {exc}"
    result["seconds"] = round(time.time() - t0, 1)
    return result


def clopper_pearson(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    from scipy.stats import beta

    a = (1 - level) / 2
    lo = 0.0 if k == 0 else float(beta.ppf(a, k, n - k + 1))
    hi = 1.0 if k == n else float(beta.ppf(1 - a, k + 1, n - k))
    return lo, hi


def _cond(r: dict) -> str:
    parts = [f"{r['force_n']:g} N"] if r.get("force_n") else []
    if r.get("noise_fraction"):
        parts.append(f"noise {100 * r['noise_fraction']:g} %")
    elif r.get("noise_v"):
        parts.append(f"noise {1e6 * r['noise_v']:g} uV")
    parts += r.get("disturbances", [])
    return ", ".join(parts)


def summarise(which: str, results: list[dict]) -> dict:
    ok = [r for r in results if "diagnosis" in r]
    failed = [{"id": r["id"], "error": r.get("error")} for r in results if "diagnosis" not in r]
    summary: dict = {"set": which, "cases": len(results), "diagnosed": len(ok), "failed": failed}
    lines = []
    if which == "nulls":
        verdicts: dict[str, int] = {}
        for r in ok:
            verdicts[r["diagnosis"]["verdict"]] = verdicts.get(r["diagnosis"]["verdict"], 0) + 1
        alarms = [r for r in ok if r["diagnosis"]["significant"]]
        wrong_verdict = [r for r in ok if r["diagnosis"]["verdict"] != "nothing to explain"]
        bad = {r["id"] for r in alarms} | {r["id"] for r in wrong_verdict}
        lo, hi = clopper_pearson(len(alarms), len(ok)) if ok else (0.0, 1.0)
        lo2, hi2 = clopper_pearson(len(bad), len(ok)) if ok else (0.0, 1.0)
        summary |= {"verdicts": verdicts, "any_significant": len(alarms),
                    "false_alarm_rate": len(alarms) / len(ok) if ok else None, "interval_95": [lo, hi],
                    "not_clean": len(bad), "not_clean_rate": len(bad) / len(ok) if ok else None,
                    "not_clean_interval_95": [lo2, hi2],
                    "alarms": [{"id": r["id"], "condition": _cond(r), "verdict": r["diagnosis"]["verdict"],
                                "significant": r["diagnosis"]["significant"]} for r in ok if r["id"] in bad]}
        lines.append(f"{'case':42s} {'condition':32s} {'err/floor':>9s}  verdict / significant")
        for r in ok:
            d = r["diagnosis"]
            lines.append(f"{r['id']:42s} {_cond(r):32s} {d['error_to_floor']:9.2f}  {d['verdict']}"
                         + (f" / {', '.join(d['significant'])}" if d["significant"] else ""))
        lines.append(f"verdicts: {verdicts}")
        lines.append(f"any significant candidate: {len(alarms)}/{len(ok)} = {summary['false_alarm_rate']:.3f} "
                     f"(95 % interval {lo:.3f}-{hi:.3f}); not 'nothing to explain' or any significant: "
                     f"{len(bad)}/{len(ok)} (95 % interval {lo2:.3f}-{hi2:.3f})")
    else:
        rows = []
        lines.append(f"{'case':44s} {'N':>5s} {'band/noise':>10s} {'err/floor':>9s}  {'named':5s} verdict; top")
        for r in ok:
            d = r["diagnosis"]
            row = {"id": r["id"], "force_n": r.get("force_n"), "truth": r["truth"], "band_ratio": r["band_ratio"],
                   "band_at": r["band_at"], "named": r["named"], "verdict": d["verdict"],
                   "error_to_floor": d["error_to_floor"], "top": d["top"]["effect"],
                   "top_significant": d["top"]["significant"], "significant": d["significant"]}
            extra = ""
            if "final" in r:
                row |= {"added": r["added"], "final_verdict": r["final"]["verdict"],
                        "final_error_to_floor": r["final"]["error_to_floor"]}
                row |= {"first_names_all": covers(r["kinds"], [d["top"]["effect"]] if d["top"]["significant"] else []),
                        "loop_names_all": covers(r["kinds"], r["added"]),
                        "final_says_what_is_left": bool(r["final"].get("cells")),
                        "final_cells": r["final"].get("cells", [])[:2]}
                extra = f"; loop {' + '.join(r['added']) or '-'} -> {r['final']['error_to_floor']:.2f}x, " \
                        f"{r['final']['verdict']}; all named: {'yes' if row['loop_names_all'] else 'no'}"
            if "after_fix" in r:
                row |= {"after_fix_verdict": r["after_fix"]["verdict"],
                        "after_fix_error_to_floor": r["after_fix"]["error_to_floor"],
                        "after_fix_significant": r["after_fix"]["significant"]}
                extra = f"; after the fix {r['after_fix']['error_to_floor']:.2f}x, {r['after_fix']['verdict']}" + (
                    f" / {', '.join(r['after_fix']['significant'])}" if r["after_fix"]["significant"] else "")
            rows.append(row)
            force = f"{r['force_n']:g}" if r.get("force_n") else "-"
            lines.append(f"{r['id']:44s} {force:>5s} {r['band_ratio']:10.1f} {d['error_to_floor']:9.2f}  "
                         f"{'yes' if r['named'] else 'no':5s} {d['verdict']}; {d['top']['effect']}"
                         f"{'' if d['top']['significant'] else ' (n.s.)'}{extra}")
        summary["rows"] = rows
        if which == "pairs":
            loop = [r for r in rows if "final_verdict" in r]
            summary |= {"loop_cases": len(loop),
                        "reach_floor": sum(r["final_verdict"] in ("explained", "nothing to explain") for r in loop),
                        "named_all_first": sum(r["first_names_all"] for r in loop),
                        "named_all_loop": sum(r["loop_names_all"] for r in loop),
                        "left_said": sum(r["final_says_what_is_left"] for r in loop
                                         if r["final_verdict"] not in ("explained", "nothing to explain"))}
            lines.append(f"pairs: {summary['reach_floor']}/{len(loop)} reach the floor (explained or nothing left); "
                         f"both changes named by the first diagnosis {summary['named_all_first']}, by the loop "
                         f"{summary['named_all_loop']}; of those left above the floor, {summary['left_said']} "
                         f"name the cells left")
        if which in ("faults", "fixed"):
            strong = [r for r in rows if r["band_ratio"] > 5]
            summary["above_5x"] = len(strong)
            summary["named_above_5x"] = sum(r["named"] for r in strong)
            summary["missed_above_5x"] = [r["id"] for r in strong if not r["named"]]
            lines.append(f"band residual > 5x noise: {len(strong)} cases, named {summary['named_above_5x']}; "
                         f"missed: {', '.join(summary['missed_above_5x']) or 'none'}")
        if which == "outside":
            explained = [r["id"] for r in rows if r["verdict"] == "explained"]
            summary["explained"] = explained
            lines.append(f"out-of-library physics called 'explained': {len(explained)}/{len(rows)}"
                         + (f" ({', '.join(explained)})" if explained else ""))
        if which == "fixed":
            after = [r for r in rows if "after_fix_verdict" in r]
            alarms = [r for r in after if r["after_fix_significant"]]
            lo, hi = clopper_pearson(len(alarms), len(after)) if after else (0.0, 1.0)
            summary |= {"after_fix_any_significant": len(alarms), "after_fix_cases": len(after),
                        "after_fix_interval_95": [lo, hi]}
            lines.append(f"after the true fix, any significant candidate: {len(alarms)}/{len(after)} "
                         f"(95 % interval {lo:.3f}-{hi:.3f})")
    for f in failed:
        lines.append(f"FAILED {f['id']}: {f['error']}")
    summary["table"] = lines
    return summary


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tests.independent.calibrate", description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--set", required=True, choices=["nulls", "faults", "pairs", "fixed", "outside"])
    parser.add_argument("--n", type=int, default=None, help="cases in the set (default 40 nulls, 20 faults, "
                                                            "3 pairs, 4 fixed)")
    parser.add_argument("--workers", type=int, default=1, help="cases run at once (each diagnose on one core)")
    parser.add_argument("--rigs", default=",".join(RIGS),
                        help=f"comma-separated rigs the set cycles through (default {','.join(RIGS)}; "
                             f"known: {', '.join(cases.RIGS)})")
    parser.add_argument("--only", default=None, help="run only the cases whose id contains this text")
    parser.add_argument("--disturb", default="",
                        help=f"comma-separated disturbances laid over every case of the set as well "
                             f"(known: {', '.join(cases.DISTURBANCES)}; e.g. flicker: 1/f sensor noise)")
    parser.add_argument("--pre-trigger", type=int, default=None,
                        help="samples before each record's first hit in every case of the set (default: the rig's)")
    parser.add_argument("--summary-only", action="store_true",
                        help="tabulate the cases already done in DIR, run nothing")
    args = parser.parse_args(argv)
    rigs = tuple(x.strip() for x in args.rigs.split(",") if x.strip())
    unknown = [x for x in rigs if x not in cases.RIGS]
    if not rigs or unknown:
        parser.error(f"--rigs: unknown rig {', '.join(unknown) or '(none given)'}; known: {', '.join(cases.RIGS)}")
    extra = [x.strip() for x in args.disturb.split(",") if x.strip()]
    unknown = [x for x in extra if x not in cases.DISTURBANCES]
    if unknown:
        parser.error(f"--disturb: unknown disturbance {', '.join(unknown)}; known: {', '.join(cases.DISTURBANCES)}")

    def all_specs():
        out = specs(args.set, args.n, rigs)
        for spec in out:
            if extra:
                spec["disturbances"] = list(dict.fromkeys(spec.get("disturbances", []) + extra))
                spec["id"] += "-" + "-".join(extra)
            if args.pre_trigger is not None:
                spec["pre_trigger"] = args.pre_trigger
                spec["id"] += f"-pre{args.pre_trigger}"
        return out

    results_dir = args.out / "results"
    results_dir.mkdir(parents=True, exist_ok=True)
    todo, results = [], []
    for spec in all_specs():
        if args.only and args.only not in spec["id"]:
            continue
        done = results_dir / f"{spec['id']}.json"
        previous = json.loads(done.read_text()) if done.exists() else None
        if previous is not None and "error" not in previous:  # a failed case is run again
            results.append(previous)
        else:
            todo.append(spec)

    def keep(result):
        (results_dir / f"{result['id']}.json").write_text(json.dumps(writers.to_jsonable(result), indent=1))
        results.append(result)
        d = result.get("diagnosis")
        state = f"{d['verdict']}, significant: {', '.join(d['significant']) or 'none'}" if d else result.get("error")
        print(f"[{len(results)}/{total}] {result['id']} ({result['seconds']} s): {state}", file=sys.stderr,
              flush=True)

    total = len(todo) + len(results)
    if args.summary_only:
        todo = []
    if args.workers <= 1:
        for spec in todo:
            keep(run_one(spec, args.out))
    else:
        with ProcessPoolExecutor(max_workers=args.workers) as pool:
            futures = [pool.submit(run_one, spec, args.out) for spec in todo]
            for fut in as_completed(futures):
                keep(fut.result())
    if args.summary_only:
        print(f"{len(results)} of {total} cases done", file=sys.stderr)
    order = {s["id"]: i for i, s in enumerate(all_specs())}
    results = [r for r in results if r["id"] in order and (not args.only or args.only in r["id"])]
    results.sort(key=lambda r: order.get(r["id"], 1 << 30))
    summary = summarise(args.set, results)
    (args.out / f"{args.set}.json").write_text(json.dumps(writers.to_jsonable(summary | {"results": results}),
                                                          indent=1))
    print("\n".join(summary["table"]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Chains from specifications: a list of ``{"step": name, ...params}`` entries built with the
registered steps, and the thesis's Table E.2 chain of a Systeminfo channel (Ch. 4.3, Eq. 4.2-4.8).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from odsuite.domain.errors import ConfigError
from odsuite.processing.executor import Chain
from odsuite.contracts.steps import Item, Reverse, Step, Tap
from odsuite.domain.systeminfo import ChannelInfo, FilterFamily, FilterType, Integration


def _fuse(items: list[Item]) -> list[Item]:
    """Merge neighbouring steps that can run as one (e.g. a scale folded into the next filter,
    filters and integrators cascaded in one ``sosfilt`` call); never across taps or reversals."""
    out: list[Item] = []
    for item in items:
        if out and isinstance(item, Step) and isinstance(out[-1], Step):
            fused = out[-1].fuse(item)
            if fused is not None:
                out[-1] = fused
                continue
        out.append(item)
    return out


def _make(registry, spec: Mapping[str, Any], fs: float, where: str) -> list[Item]:
    if "tap" in spec:
        if set(spec) != {"tap"} or not isinstance(spec["tap"], str) or not spec["tap"]:
            raise ConfigError(f"{where}: a tap is {{'tap': NAME}} alone, got {dict(spec)!r}")
        return [Tap(spec["tap"])]
    if "step" not in spec:
        raise ConfigError(f"{where}: expected {{'step': NAME, ...parameters}}, got {dict(spec)!r}")
    name = spec["step"]
    if name not in registry:
        known = ", ".join(registry.names())
        raise ConfigError(f"{where}: unknown processing step {name!r} (known: {known})")
    params = {k: v for k, v in spec.items() if k != "step"}
    try:
        made = registry.get(name)(fs=fs, **params)
    except TypeError as exc:  # wrong or missing parameter names
        raise ConfigError(f"{where}: step {name!r}: {exc}") from None
    made = made if isinstance(made, list) else [made]
    for m in made:
        if not isinstance(m, (Step, Tap, Reverse)):
            raise ConfigError(f"{where}: step {name!r} made {type(m).__name__}, not a processing step")
    return made


def _one_line(value: Any) -> str:
    """A value in a message: its repr on one line (an array's runs over several), cut short."""
    text = " ".join(repr(value).split())
    return text if len(text) <= 80 else text[:77] + "..."


def build_chain(specs: Sequence[Mapping[str, Any]], *, fs: float, registry,
                where: str = "chain") -> Chain:
    """A chain from a list of ``{"step": name, ...params}`` (and ``{"tap": name}``) entries.

    Steps are looked up in ``registry`` (the processing steps of the registries at hand, e.g. a
    project's ``project.registries.processing_steps``), so a lab's own registered step is used by
    name. A final tap "output" is added when the chain does not end in a tap.
    """
    if not (isinstance(fs, (int, float)) and fs > 0):
        raise ConfigError(f"{where}: sampling rate must be > 0 Hz, got {fs!r}")
    # a text or a single table is iterable too, and would be taken apart into wrong entries
    if isinstance(specs, (str, bytes, Mapping)) or not isinstance(specs, Iterable):
        raise ConfigError(f"build_chain: 'specs' must be a list of steps (tables with a 'step' or 'tap' entry), "
                          f"got {_one_line(specs)}")
    specs = list(specs)
    for k, spec in enumerate(specs):
        if not isinstance(spec, Mapping):
            raise ConfigError(f"{where}[{k}]: expected a table {{'step': NAME, ...}}, got {_one_line(spec)}")
    items: list[Item] = []
    specs = [dict(s) for s in specs]
    for k, spec in enumerate(specs):
        items += _make(registry, spec, float(fs), f"{where}[{k}]")
    if not items or not isinstance(items[-1], Tap):
        items.append(Tap("output"))
        specs.append({"tap": "output"})
    return Chain(tuple(_fuse(items)), tuple(specs), float(fs))


#: Names of a quantity after 0, 1, 2 integrations.
_INTEGRALS = {"acceleration": ("acceleration", "velocity", "displacement")}


def stage_names(quantity: str) -> tuple[str, str, str]:
    """Tap names of a channel's signal, its integral and double integral."""
    return _INTEGRALS.get(quantity, (quantity, f"{quantity}_integral", f"{quantity}_integral2"))


def _filter_spec(ch: ChannelInfo) -> dict:
    return {"step": "iir", "family": FilterFamily(ch.filter_family).name.lower(),
            "type": FilterType(ch.filter_type).name.lower(), "order": int(ch.filter_order),
            "cutoff_low": ch.cutoff_low, "cutoff_high": ch.cutoff_high,
            "ripple_db": ch.ripple_db, "attenuation_db": ch.attenuation_db,
            "zero_phase": bool(ch.zero_phase)}


def channel_chain_spec(ch: ChannelInfo) -> list[dict]:
    """The step list of a channel, in the order of Table E.2 and the Signal Processor VI.

    convert -> (invert) -> (micro) -> offset -> filter 1 -> [tap] -> integrate -> filter 2 ->
    [tap] -> integrate -> filter 3 -> [tap]. Filters run when their bit of ``filters_on`` is set.
    The VI's front panel (App. F, "Signal Processing (Filters & Integration) ii") pairs an integral
    switch with filter 1 and with filter 2, then has filter 3: single integration is filter 1,
    integrate, filter 2, filter 3 (the tap after filter 3 is the velocity); no integration runs
    the three filters in a row on the measured quantity.
    """
    integration = Integration(ch.integration)
    on = 7 if ch.filters_on == 16 else int(ch.filters_on)  # legacy 16 = all on (erratum 8)
    names = stage_names(ch.quantity)
    spec: list[dict] = [{"step": "convert", "sensitivity": ch.sensitivity, "daq_gain": ch.daq_gain}]
    if ch.invert:
        spec.append({"step": "invert"})
    if ch.micro_units:
        spec.append({"step": "micro"})
    if ch.offset_length > 0:
        spec.append({"step": "offset", "start": int(ch.offset_start), "length": int(ch.offset_length)})
    integrate = {"step": "integrate", "rule": ch.integration_rule}
    filters = [_filter_spec(ch) if on & (1 << k) else None for k in range(3)]
    if integration is Integration.NONE:
        spec += [f for f in filters if f] + [{"tap": names[0]}]
    elif integration is Integration.SINGLE:
        spec += [f for f in filters[:1] if f] + [{"tap": names[0]}, integrate]
        spec += [f for f in filters[1:] if f] + [{"tap": names[1]}]
    else:
        spec += [f for f in filters[:1] if f] + [{"tap": names[0]}, integrate]
        spec += [f for f in filters[1:2] if f] + [{"tap": names[1]}, integrate]
        spec += [f for f in filters[2:] if f] + [{"tap": names[2]}]
    return spec


def channel_unit(ch: ChannelInfo, stage: int) -> str:
    """SI unit of a channel's signal after ``stage`` integrations (micro-units get a "u" prefix)."""
    unit = ch.unit
    if stage:
        base = {"m/s^2": ("m/s", "m"), "m/s": ("m", "m s")}.get(unit)
        unit = base[stage - 1] if base else f"{unit} s" if stage == 1 else f"{unit} s^2"
    return f"u{unit}" if ch.micro_units else unit


def chain_for_channel(ch: ChannelInfo, *, registry, where: str = "channel") -> Chain:
    """The Table E.2 chain of one channel (see :func:`channel_chain_spec`)."""
    return build_chain(channel_chain_spec(ch), fs=ch.sampling_rate, registry=registry, where=where)

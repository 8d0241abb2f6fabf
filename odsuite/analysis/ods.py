"""Operating deflection shapes from operating records (a running machine, no force measured):
cross-spectra of every response to a reference sensor, scaled by the reference's autospectrum.
A hammer record's transient is taken whole (one unwindowed segment: lines fs / n).

At a frequency line f the shape of response i is G_ri(f) / sqrt(G_rr(f)) (Welch, Hann window,
"spectrum" scaling): its magnitude is the response's rms amplitude in that line wherever the
response is coherent with the reference (|G_ri|^2 = G_rr G_ii), its phase the phase relative to
the reference. Dividing by G_rr instead would give the transmissibility G_ri / G_rr; the scaling
by sqrt(G_rr) puts the reference's own amplitude back, so the shape is in the responses' units.
Sensors on a rig's bodies are then solved into generalized coordinates at G like any record
(displacement = -acceleration / omega^2).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.signal

from odsuite.domain import arguments
from odsuite.domain.errors import ConfigError
from odsuite.domain.rig import COORDINATES

#: default line spacing (Hz): resolves a 1 %-damped mode at 25 Hz (half-power width 0.5 Hz)
RESOLUTION_HZ = 0.25
#: below 25 Hz the lines are this fraction of the frequency asked: half the half-power width of a
#: 1 %-damped mode there (a building's 1.88 Hz mode got 0.195 Hz lines and its ODS at 1.953 Hz)
RELATIVE_RESOLUTION = 0.01
#: at least this many Welch segments (Hann, half overlap), so that the cross-spectra are averages
MIN_SEGMENTS = 8


@dataclass(frozen=True)
class OperatingShape:
    """The ODS of one experiment at one frequency line. ``shape``: sensor -> complex rms amplitude
    in ``units[sensor]``, phase relative to the reference; ``coherence``: each response's
    coherence with the reference at that line; ``coordinates``: body -> six complex generalized
    coordinates at G (m, rad) of the displacement, when the project has a rig."""

    experiment: str
    reference: str
    requested_hz: float
    frequency_hz: float
    resolution_hz: float
    n_segments: int
    shape: dict[str, complex]
    units: dict[str, str]
    coherence: dict[str, float]
    coordinates: dict[str, np.ndarray] = field(default_factory=dict)
    notes: tuple[str, ...] = ()

    def to_dict(self) -> dict:
        """JSON-ready: {"frequency_hz", "requested_hz", "resolution_hz", "reference", "shape":
        {sensor: [re, im]}, "units", "coherence", "coordinates": {body: {coordinate: [re, im]}}}."""
        return {
            "experiment": self.experiment,
            "frequency_hz": self.frequency_hz,
            "requested_hz": self.requested_hz,
            "resolution_hz": self.resolution_hz,
            "segments": self.n_segments,
            "reference": self.reference,
            "shape": {n: [float(v.real), float(v.imag)] for n, v in self.shape.items()},
            "units": dict(self.units),
            "coherence": {n: float(v) for n, v in self.coherence.items()},
            "coordinates": {b: {c: [float(v.real), float(v.imag)] for c, v in zip(COORDINATES, d)}
                            for b, d in self.coordinates.items()},
            "coordinate_units": {"x": "m", "y": "m", "z": "m", "theta": "rad", "phi": "rad", "psi": "rad"},
        }


def segment_length(n_samples: int, fs: float, frequency_hz: float) -> int:
    """Welch segment: a power of two giving lines of RESOLUTION_HZ, or RELATIVE_RESOLUTION of
    ``frequency_hz`` where that is finer, or finer still, when the record holds MIN_SEGMENTS of
    them, else the longest power of two that still gives MIN_SEGMENTS."""
    want = 2 ** int(np.ceil(np.log2(fs / min(RESOLUTION_HZ, RELATIVE_RESOLUTION * frequency_hz))))
    most = 2 ** int(np.floor(np.log2(max(2 * n_samples // (MIN_SEGMENTS + 1), 2))))
    return int(max(min(want, most), 2))


def operating_shape(project, experiment: str, reference: str, frequency_hz: float) -> OperatingShape:
    """The ODS of ``experiment`` at the Welch line nearest ``frequency_hz``, referenced to the
    response channel named ``reference`` (see the module's text)."""
    from odsuite.analysis.modal_project import physical, response_columns
    from odsuite.contracts.solvers import harmonic_shapes

    frequency_hz = arguments.real("operating_shape", "frequency_hz", frequency_hz, positive=True)
    where = f"{project.path}: experiment {experiment!r}"
    exp = project.experiment(experiment)
    fs = exp.sampling_rate
    if not (np.isfinite(frequency_hz) and 0 < frequency_hz < fs / 2):
        raise ConfigError(f"--at: the ODS frequency must lie between 0 and the Nyquist frequency {fs / 2:g} Hz, "
                          f"got {frequency_hz!r} Hz")
    cols = response_columns(exp)
    names = [exp.channel_names[k] for k in cols]
    if reference not in names:
        raise ConfigError(f"{where}: --reference {reference!r} is not a response channel "
                          f"(responses: {', '.join(names)})")
    data = physical(exp)[:, cols]
    # a hammer record holds its transient whole: one segment of the record's length, unwindowed,
    # gives lines fs / n (Welch segments of a 0.4 s record gave 10-20 Hz lines and cut the transient)
    hammer = exp.excitation is not None
    nper = data.shape[0] if hammer else segment_length(data.shape[0], fs, frequency_hz)
    if not hammer and data.shape[0] < 2 * nper:
        raise ConfigError(f"{where}: {data.shape[0]} samples are too few for an ODS (at least {2 * nper})")
    r = names.index(reference)
    kw = {"fs": fs, "window": "boxcar" if hammer else "hann", "nperseg": nper, "noverlap": 0 if hammer else nper // 2,
          "scaling": "spectrum", "axis": 0}
    freq, g_rr = scipy.signal.welch(data[:, r], **kw)
    line = int(np.argmin(np.abs(freq - frequency_hz)))
    if freq[line] <= 0:  # a record too short for the frequency: its shape has no displacement
        apart = freq[1] - freq[0] if len(freq) > 1 else fs
        raise ConfigError(f"{where}: the line nearest {frequency_hz:g} Hz is 0 Hz (lines {apart:g} Hz apart "
                          f"on {data.shape[0]} samples): too few samples for an ODS there")
    if g_rr[line] <= 0:
        raise ConfigError(f"{where}: reference {reference!r} holds no signal at {freq[line]:g} Hz")
    _, g_ri = scipy.signal.csd(data[:, [r]], data, **kw)
    _, g_ii = scipy.signal.welch(data, **kw)
    g_ri, g_ii = g_ri[line], g_ii[line]
    shape = g_ri / np.sqrt(g_rr[line])
    with np.errstate(invalid="ignore", divide="ignore"):
        coherence = np.where(g_ii > 0, np.abs(g_ri) ** 2 / (g_rr[line] * g_ii), 0.0)
    units = {n: exp.systeminfo.channels[k].unit for n, k in zip(names, cols)}
    coordinates: dict[str, np.ndarray] = {}
    notes: list[str] = []
    rig = project.rig
    if rig is not None:
        sensors = {s.name: s for s in rig.accelerometers}
        omega = 2 * np.pi * freq[line]
        disp = {n: -v / omega**2 for n, v in zip(names, shape) if n in sensors}
        if disp:
            coordinates = harmonic_shapes(rig, disp, project.registries.coordinate_solvers, f"{where}: ODS")
        else:
            notes.append(f"no response channel is one of the accelerometers of rig {rig.name!r}: no coordinates")
    weak = [n for n, c in zip(names, coherence) if c < 0.5]
    if hammer:
        notes.append(f"a hammer record: the spectrum of the whole record ({fs / nper:.3g} Hz lines), one segment, "
                     "so the coherence is 1 by construction and says nothing")
    elif weak:  # an ODS is a shape only where the responses move with the reference
        notes.append(f"coherence with {reference} below 0.5 at {freq[line]:g} Hz: {', '.join(weak)}")
    return OperatingShape(experiment, reference, float(frequency_hz), float(freq[line]), float(fs / nper),
                          1 if hammer else int((data.shape[0] - nper) // (nper // 2) + 1), dict(zip(names, shape)), units,
                          dict(zip(names, coherence)), coordinates, tuple(notes))


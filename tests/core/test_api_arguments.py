"""What a notebook most often gets wrong calling odsuite.api gets one line naming the function,
the argument and the value: before, a path given for the open project said "'str' object has no
attribute 'model_revisions'", a text seed "invalid literal for int()", and a single experiment name
was read letter by letter."""

from __future__ import annotations

import signal
from pathlib import Path

import numpy as np
import pytest

from odsuite import api
from odsuite.contracts.daq import AcquisitionSettings
from odsuite.domain.errors import ConfigError


@pytest.fixture(scope="module")
def project_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("api") / "p.h5"
    sim = api.registries().daq_backends.get("sim")
    with api.create_project(path):
        pass
    with api.open_project(path, "a") as p:
        api.acquire(p, sim, "T2", AcquisitionSettings(n_samples=2048), scenario="T2", seed=1)
    return path


@pytest.mark.parametrize("function", ["history", "compare", "diagnose", "prepare", "current_revision"])
def test_a_path_for_the_open_project_is_named(project_path, function):
    with pytest.raises(ConfigError, match=rf"^{function}: expected an open project \(open_project\(path\)\) as its "
                                          rf"first argument, got str '.*p\.h5'$"):
        getattr(api, function)(str(project_path))


def test_one_name_for_a_list_of_experiments_is_named(project_path):
    with api.open_project(project_path) as p:
        with pytest.raises(ConfigError, match=r"^prepare: 'experiments' is a list of experiment names, got 'T2'$"):
            api.prepare(p, experiments="T2")
        with pytest.raises(ConfigError, match=r"^process_experiment: 'name' names an experiment \(text\), got 3$"):
            api.process_experiment(p, 3)
        # a list of names, and an iterator (left unread by the check), still work
        assert [e.name for e in api.prepare(p, experiments=["T2"])] == ["T2"]
        assert [e.name for e in api.prepare(p, experiments=iter(["T2"]))] == ["T2"]


@pytest.mark.parametrize("options, message", [
    ({"seed": "x"}, "acquire: backend option 'seed': expected an integer, got 'x'"),
    ({"seed": 1.5}, "acquire: backend option 'seed': expected an integer, got 1.5"),
    ({"force_peak": "a"}, "acquire: backend option 'force_peak': expected a number, got 'a'"),
    ({"scenario": 3}, "acquire: backend option 'scenario': expected text, got 3"),
    ({"bogus": 1}, "acquire: the backend takes no option 'bogus' (its options: adc_bits, base_rms, capture, "
                   "contact_ms, direction, force_body, force_peak, force_rms, noise, operating, point, scenario, "
                   "seed, truth_rig)"),
])
def test_a_backend_option_of_the_wrong_type_is_named(project_path, options, message):
    sim = api.registries().daq_backends.get("sim")
    with api.open_project(project_path, "a") as p:
        with pytest.raises(ConfigError) as err:
            api.acquire(p, sim, "new", AcquisitionSettings(n_samples=1024), **options)
        assert str(err.value) == message
        assert "new" not in p.experiment_names()


def test_a_backend_name_or_a_settings_dict_is_named(project_path):
    sim = api.registries().daq_backends.get("sim")
    with api.open_project(project_path, "a") as p:
        with pytest.raises(ConfigError, match=r"^acquire: backend must be a registered acquisition backend "
                                              r"\(registries\(\)\.daq_backends\.get\(NAME\)\), got str 'sim'$"):
            api.acquire(p, "sim", "new")
        with pytest.raises(ConfigError, match=r"^acquire: settings must be an AcquisitionSettings, got dict$"):
            api.acquire(p, sim, "new", {"n_samples": 1024})
        # a whole float is an integer seed: the record is the one seed 2 gives
        exp, _ = api.acquire(p, sim, "seed2", AcquisitionSettings(n_samples=1024), scenario="T2", seed=2.0)
        twin, _ = api.acquire(p, sim, "seed2b", AcquisitionSettings(n_samples=1024), scenario="T2", seed=2)
        assert (exp.raw() == twin.raw()).all()


@pytest.mark.parametrize("field, value", [("sampling_rate", "x"), ("n_samples", True), ("mode", 1)])
def test_a_setting_of_the_wrong_type_is_named(field, value):
    with pytest.raises(ConfigError, match=rf"^acquisition setting '{field}': must be (a number|text), got {value!r}$"):
        AcquisitionSettings(**{field: value})


def test_a_function_that_opens_the_project_itself_asks_for_its_path(project_path):
    # the output-only modes open the file in their own worker processes: a path, not an open project
    with api.open_project(project_path) as p:
        with pytest.raises(ConfigError, match=r"^experiment_output_only_modes: expected a project file's path as its "
                                              r"first argument, got Project "):
            api.experiment_output_only_modes(p, "T2")


@pytest.fixture(scope="module")
def noise_frf():
    rng = np.random.default_rng(0)
    return api.estimate_frf([rng.standard_normal(1024)], [rng.standard_normal(1024)], 1000.0)


@pytest.mark.parametrize("options, message", [
    # an order of 0 or below grew the nested fit bands without end (and memory with them)
    ({"max_order": 0}, "'max_order' must be an integer of at least 2, got 0"),
    ({"max_order": -1}, "'max_order' must be an integer of at least 2, got -1"),
    ({"max_order": "x"}, "'max_order' must be an integer of at least 2, got 'x'"),
    ({"frequencies": [float("nan")]}, "'frequencies' must be a finite number > 0, got nan"),
    ({"frequencies": 12.0}, "'frequencies' must be a list of frequencies in Hz, got 12.0"),
    ({"f_band": (1.0, float("inf"))}, "'f_band' must be a finite number >= 0, got inf"),
])
def test_frf_modes_refuses_a_wrong_fit_option(noise_frf, options, message):
    def hung(*_):
        raise TimeoutError("frf_modes still running after 20 s")

    old = signal.signal(signal.SIGALRM, hung)
    signal.alarm(20)
    try:
        with pytest.raises(ConfigError) as err:
            api.frf_modes(noise_frf, **options)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    assert str(err.value) == f"frf_modes: {message}"


def test_frf_modes_refuses_what_is_not_an_frf_set():
    with pytest.raises(ConfigError, match=r"^frf_modes: 'frf' must be an FrfSet \(estimate_frf\), got None$"):
        api.frf_modes(None)


@pytest.mark.parametrize("projects", ["base.h5", Path("base.h5")])
def test_run_batch_refuses_one_path_for_the_list(tmp_path, monkeypatch, projects):
    # a path's characters were run as projects, one task each
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError) as err:
        api.run_batch("info", projects, workers=1)
    assert str(err.value) == f"run_batch: 'projects' is a list of project paths, got {projects!r}"
    assert list(tmp_path.iterdir()) == []


def test_run_batch_refuses_a_text_worker_count(project_path):
    with pytest.raises(ConfigError, match=r"^run_batch: 'workers' must be an integer from 1 to \d+ \(4 per core\), "
                                          r"got '2'$"):
        api.run_batch("info", [project_path], workers="2")


def test_a_projects_own_methods_refuse_a_wrong_argument_without_blaming_the_file(project_path):
    # before, each said "project file is damaged (...)", and channel 1.5 was read as channel 1
    with api.open_project(project_path) as p:
        e = p.experiment("T2")
        for call, message in [
            (lambda: p.experiment(5), "Project.experiment: 'name' must be text, got 5"),
            (lambda: p.read_derived("T2", None), "Project.read_derived: 'kind' must be text, got None"),
            (lambda: e.raw("a"), "Experiment.raw: 'start' must be an integer, got 'a'"),
            (lambda: e.raw(0, 1.5), "Experiment.raw: 'stop' must be an integer or None, got 1.5"),
            (lambda: e.raw(0, 10, channels=1.5), "Experiment.raw: 'channels' must be a channel's index or name or a "
                                                 "list of them, got 1.5"),
            (lambda: e.channel_index(1.5), "Experiment.channel_index: 'channel' must be a channel's index or name, "
                                           "got 1.5"),
        ]:
            with pytest.raises(ConfigError) as err:
                call()
            assert str(err.value) == message
        assert e.raw(np.int64(2), 4, channels=[0, e.channel_names[1]]).shape == (2, 2)
    with pytest.raises(api.OdsuiteError) as err:
        e.raw(0, 10)
    assert str(err.value) == f"{project_path}: project is closed (open_project again to read it)"


def test_a_wrong_argument_to_a_projects_function_leaves_the_project_unchanged(project_path):
    # workers=0 ran (on every core) and full_fits=-1 fitted all but the last candidate; a text
    # chunk, a number for the chain or the revision raised inside
    before = project_path.read_bytes()
    with api.open_project(project_path, "a") as p:
        rev = api.current_revision(p)
        for call, message in [
            (lambda: api.process_experiment(p, "T2", workers=0),
             "process_experiment: 'workers' must be an integer of at least 1, got 0"),
            (lambda: api.process_experiment(p, "T2", chunk="x"),
             "process_experiment: 'chunk' must be an integer of at least 1, got 'x'"),
            (lambda: api.process_experiment(p, "T2", chain=5),
             "process_experiment: 'chain' must be a list of steps {'step': NAME, ...}, got 5"),
            (lambda: api.diagnose(p, full_fits=-1), "diagnose: 'full_fits' must be an integer of at least 1, got -1"),
            (lambda: api.diagnose(p, full_fits="x"), "diagnose: 'full_fits' must be an integer of at least 1, got 'x'"),
            (lambda: api.add_effect(p, None), "add_effect: 'name' names an effect (text), got None"),
            (lambda: api.add_effect(p, 5), "add_effect: 'name' names an effect (text), got 5"),
            (lambda: api.compare(p, revision=5), "compare: 'revision' must be a model revision (an entry of "
             "project.model_revisions() or current_revision(project)) or None for the current one, got 5"),
            # a dict without effects was compared as the rig's model, its revision None
            (lambda: api.compare(p, revision={"x": 1}), "compare: 'revision' must be a model revision (an entry of "
             "project.model_revisions() or current_revision(project)) or None for the current one, got {'x': 1}"),
            (lambda: api.revision_model(p, {"effects": 5}),
             "revision_model: 'revision' field 'effects' must be a list of {'effect': NAME, ...}, got 5"),
            (lambda: api.ods_coordinates(p, "T2", "10"),
             "ods_coordinates: 'frequency_hz' must be a finite number > 0, got '10'"),
            (lambda: p.set_revision_metrics(0, 5), "Project.set_revision_metrics: 'metrics' must be a dict of metrics, "
                                                   "got 5"),
            # a NaN error was stored, and history showed it
            (lambda: p.set_revision_metrics(0, {"error": float("nan")}),
             "Project.set_revision_metrics: metric 'error' must be a finite number, got nan"),
        ]:
            with pytest.raises(ConfigError) as err:
                call()
            assert str(err.value) == message
        assert api.revision_model(p, rev).shared is not None  # a stored revision is one
    assert project_path.read_bytes() == before


@pytest.mark.parametrize("call, message", [
    (lambda: api.open_project(None), "open_project: 'path' must be a project file's path, got None"),
    (lambda: api.open_project(5), "open_project: 'path' must be a project file's path, got 5"),
    (lambda: api.estimate_frf([np.ones(64)], [np.ones(64)], 0.0), "estimate_frf: 'fs' must be a finite number > 0, "
                                                                 "got 0.0"),
    (lambda: api.estimate_frf([np.ones(64)], [np.ones(64)], float("nan")),
     "estimate_frf: 'fs' must be a finite number > 0, got nan"),
    (lambda: api.estimate_frf([np.ones(64)], [np.ones(64)], 100.0, window=np.ones(5)),
     "estimate_frf: 'window' must be 64 samples (or 64 x 2: the force's, then each response's), got shape (5,)"),
    (lambda: api.estimate_frf([np.ones(64)], [np.ones(64)], 100.0, force_unit="parsec"),
     "estimate_frf: 'force_unit' must be a force unit (N, kN, mN, lbf), got 'parsec'"),
    (lambda: api.spectral_matrix(np.ones((256, 2)), 100.0, 0),
     "spectral_matrix: 'nperseg' must be an integer of at least 2, got 0"),
    # an empty record reached numpy's FFT ("Invalid number of FFT data points (0)")
    (lambda: api.estimate_frf([np.array([])], [np.array([])], 1000.0),
     "estimate_frf: 'forces' must be records of 2 or more samples each, got hit 0 of shape (0,)"),
    (lambda: api.estimate_frf(np.array([]), np.array([]), 1000.0),
     "estimate_frf: 'forces' must be records of 2 or more samples each, got hit 0 of shape (0,)"),
    (lambda: api.estimate_frf([], [], 1000.0), "estimate_frf: 'forces' must be a list of records, one per hit, got []"),
    (lambda: api.estimate_frf([np.ones(64), np.ones(64)], [np.ones(64)], 1000.0),
     "estimate_frf: 'responses' must be one record per hit, as 'forces' (2), got 1"),
    # arrays whose hits do not match (2 force records and 64 response records before)
    (lambda: api.estimate_frf(np.ones((2, 64)), np.ones(64), 1000.0),
     "estimate_frf: 'responses' must be an array of hits x samples (x outputs), as 'forces' is an array of hits x "
     "samples, got an array of shape (64,)"),
    (lambda: api.estimate_frf(np.ones(64), [np.ones(64)], 1000.0),
     "estimate_frf: 'responses' must be an array of samples (x outputs), as 'forces' is an array of samples, got "
     "[array([1., 1., 1., 1., 1., 1., 1., 1., 1., 1., 1., 1., 1., 1., 1., 1., 1., 1..."),
    (lambda: api.estimate_frf(np.ones((2, 2, 64)), np.ones((2, 2, 64)), 1000.0),
     "estimate_frf: 'forces' must be a list of records, one per hit (or an array: samples, or hits x samples), "
     "got an array of shape (2, 2, 64)"),
    # a 1-D signal is one output; other shapes gave numpy's AxisError or text's ValueError
    (lambda: api.spectral_matrix(np.ones((4, 4, 4)), 100.0, 4),
     "spectral_matrix: 'y' must be samples x outputs (2 or more samples), got an array of shape (4, 4, 4)"),
    (lambda: api.spectral_matrix(np.ones(1), 100.0, 4),
     "spectral_matrix: 'y' must be samples x outputs (2 or more samples), got an array of shape (1,)"),
    (lambda: api.spectral_matrix("abc", 100.0, 4), "spectral_matrix: 'y' must be numbers, samples x outputs, got 'abc'"),
    (lambda: api.parse_force_point(None),
     "parse_force_point: 'value' must be three numbers 'X,Y,Z' (text or a list), got None"),
    (lambda: api.parse_force_direction(5), "parse_force_direction: 'value' must be an axis (+x, -x, +y, -y, +z, -z) "
                                           "or three numbers 'dx,dy,dz', got 5"),
    (lambda: api.rig_from_dict(5, api.registries().sensor_types),
     "rig_from_dict: 'data' must be a rig's tables as a dict (a parsed rig file), got 5"),
    (lambda: api.parse_ctr(None),
     "parse_ctr: 'text' must be the text of a .CTR file (read_ctr reads one from its path), got None"),
])
def test_a_wrong_argument_is_one_line_naming_the_function(call, message):
    with pytest.raises(ConfigError) as err:
        call()
    assert str(err.value) == message


def test_estimate_frf_takes_one_hit_or_an_array_of_hits_as_arrays():
    """One hit as plain 1-D arrays, and a 2-D array of hits (3-D responses: hits x samples x
    outputs), give the FRFs of the same hits given as lists."""
    rng = np.random.default_rng(1)
    f, x = rng.standard_normal((2, 256)), rng.standard_normal((2, 256, 3))
    as_lists = api.estimate_frf([f[0]], [x[0]], 1000.0)
    for one in (api.estimate_frf(f[0], x[0], 1000.0), api.estimate_frf(f[:1], x[:1], 1000.0)):
        assert one.n_averages == 1
        np.testing.assert_array_equal(one.H, as_lists.H)
        np.testing.assert_array_equal(one.coherence, as_lists.coherence)
    single = api.estimate_frf(f[0], x[0, :, 0], 1000.0)  # one output as a 1-D array
    np.testing.assert_array_equal(single.H, as_lists.H[:1])
    both = api.estimate_frf(f, x, 1000.0)
    assert both.n_averages == 2 and both.H.shape == (3, 129)
    np.testing.assert_array_equal(both.H, api.estimate_frf(list(f), list(x), 1000.0).H)
    np.testing.assert_array_equal(api.estimate_frf(f, x[:, :, 0], 1000.0).H, both.H[:1])


def test_spectral_matrix_takes_a_1d_signal_as_one_output():
    y = np.random.default_rng(2).standard_normal(4096)
    freq, G = api.spectral_matrix(y, 100.0, 256)
    freq_2d, G_2d = api.spectral_matrix(y[:, None], 100.0, 256)
    assert G.shape == (129, 1, 1)
    np.testing.assert_array_equal(freq, freq_2d)
    np.testing.assert_array_equal(G, G_2d)


def test_a_wrong_value_is_shown_on_one_line():
    from odsuite.domain.arguments import shown

    assert shown(np.ones((3, 40))) == "array([[1., 1., 1., 1., 1., 1., 1., 1., 1., 1., 1., 1., 1., 1., 1., 1., 1., 1..."
    assert shown("a\nb") == "'a\\nb'"  # text keeps its escapes


def test_create_project_and_load_rig_name_a_wrong_rig_argument(tmp_path):
    with pytest.raises(ConfigError) as err:
        api.create_project(tmp_path / "c.h5", rig=5)
    assert str(err.value) == ("create_project: 'rig' must be a Rig, a registered rig's name, a .toml rig file or "
                              "None, got 5")
    assert list(tmp_path.iterdir()) == []
    rig_file = tmp_path / "r.toml"
    rig_file.write_text('name = "r"\n')
    with pytest.raises(ConfigError) as err:
        api.load_rig(rig_file, None)
    assert str(err.value) == ("load_rig: 'sensor_types' must be the registry of sensor types "
                              "(registries().sensor_types), got None")

"""What the command line does at start-up to start sooner, checked to change nothing a user sees:
only the command named is built (its options and help as in the whole app)."""

from __future__ import annotations

import sys

import typer

from odsuite.cli import main

app_module = sys.modules["odsuite.cli.app"]


def _signature(command) -> list:
    """What click parses and shows of a command: each parameter's names, kind, default and help."""
    return [(p.name, tuple(p.opts), type(p).__name__, repr(p.default), getattr(p, "help", None), p.required)
            for p in command.params] + [command.help]


def test_the_command_named_alone_is_built_as_in_the_whole_app(capsys):
    for _ in range(2):  # plugin commands (the demo plugin's) are registered at each run, here twice
        assert main(["plugins", "--json"]) == 0
    capsys.readouterr()
    whole = typer.main.get_command(app_module.app)
    assert len(whole.commands) > 20 and "demo" in whole.commands
    for name, command in whole.commands.items():
        narrowed = typer.main.get_command(app_module._commands_for([name, "x"]))
        assert list(narrowed.commands) == [name]
        assert _signature(narrowed.commands[name]) == _signature(command), name
        assert _signature(narrowed) == _signature(whole)  # --version and completion stay
    for args in ([], ["--help"], ["--version"], ["inf"], ["x", "info"]):
        assert app_module._commands_for(args) is app_module.app


def test_the_collector_is_off_while_the_program_loads_and_on_when_its_command_runs(monkeypatch, capsys):
    """As the ``odsuite`` program, start-up runs without the garbage collector (its objects live as
    long as the program); the command itself runs with it, the start-up's objects frozen out of it."""
    import gc
    import signal

    handlers = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}  # the program ignores them at its end
    seen = []
    monkeypatch.setattr(app_module, "_AS_PROGRAM", True)
    monkeypatch.setattr(app_module.console, "print", lambda *a, **k: seen.append(gc.isenabled()))
    gc.disable()
    try:
        assert main(["plugins"]) == 0
        assert seen == [True] and gc.isenabled() and gc.get_freeze_count() > 0
        gc.disable()  # a command that fails before it runs leaves the collector on as well
        assert main(["info", "no-such-file.h5"]) == 1
        assert gc.isenabled()
        # a summary command (info, history, model) runs with it off to its end, then exits at once
        ended = []
        monkeypatch.setattr(app_module, "_SUMMARY", True)
        monkeypatch.setattr(app_module, "_exit_now", lambda code: ended.append((code, gc.isenabled())))
        gc.disable()
        assert main(["info", "no-such-file.h5"]) == 1
        assert ended == [(1, False)]
    finally:
        gc.unfreeze()
        gc.enable()
        for s, handler in handlers.items():
            signal.signal(s, handler)
    capsys.readouterr()


def test_info_imports_only_what_it_shows(tmp_path, capsys):
    """`info` on a processed project, once the installed entry points are cached: the same output
    as the run that filled the cache, and none of importlib.metadata (nor the email parser it
    reads metadata with), the writer lock's socket, scipy, the model, the comparison, the
    contracts of the DAQ backends, renderers and importers (registered by name), nor the TOML
    reader (a stored rig is JSON), the rigid-body kinematics (the rig alone says which sensors
    a body carries), rich (its tables are plain text) nor hashlib (OpenSSL: the errors' stamp
    is read with the built-in SHA-256)."""
    import json
    import os
    import subprocess

    p = tmp_path / "p.h5"
    for argv in (["new", p], ["acquire", p, "--daq", "sim", "--name", "T1", "--scenario", "T1", "--seed", "1",
                              "--samples", "2048"], ["process", p]):
        assert main([str(a) for a in argv]) == 0
    capsys.readouterr()
    not_needed = ("importlib.metadata", "email", "socket", "scipy", "odsuite.domain.model",
                  "odsuite.analysis.comparison", "matplotlib", "odsuite.contracts.daq",
                  "odsuite.contracts.renderers", "odsuite.contracts.importers", "tomllib",
                  "odsuite.domain.rigidbody", "rich", "hashlib")
    code = ("import contextlib, io, json, sys; from odsuite.cli import main\n"
            "with contextlib.redirect_stdout(io.StringIO()) as out: code = main(['info', sys.argv[1]])\n"
            f"print(json.dumps([code, out.getvalue(), sorted(m for m in {not_needed!r} if m in sys.modules)]))")
    env = {**os.environ, "ODSUITE_CACHE_DIR": str(tmp_path / "cache")}
    runs = [subprocess.run([sys.executable, "-c", code, str(p)], capture_output=True, text=True, timeout=300,
                           env=env, cwd=tmp_path) for _ in range(2)]
    assert [r.returncode for r in runs] == [0, 0], runs[0].stderr + runs[1].stderr
    first, cached = (json.loads(r.stdout) for r in runs)
    assert first[0] == cached[0] == 0 and "model revisions" in cached[1] and cached[1] == first[1]
    assert "importlib.metadata" in first[2]  # the run that filled the cache read the metadata
    assert cached[2] == []
    # as the odsuite program, info loads numpy with no BLAS worker thread (one spinning beside the
    # command is CPU a shared machine takes from it): the process ends with its main thread alone
    # (seen by an exit handler: the program ends in main, without the interpreter's teardown)
    if os.path.isdir("/proc/self/task"):
        program = ("import atexit, contextlib, io, os, sys; shown = sys.argv[2]; sys.argv = ['odsuite', 'info', sys.argv[1]]\n"
                   "from odsuite.cli import main\n"
                   "out = io.StringIO()\n"
                   "atexit.register(lambda: sys.__stdout__.write(f\"{len(os.listdir('/proc/self/task'))} {out.getvalue() == shown}\\n\"))\n"
                   "with contextlib.redirect_stdout(out): code = main()\n"
                   "print('main returned', code)")
        env.pop("OPENBLAS_NUM_THREADS", None)
        run = subprocess.run([sys.executable, "-c", program, str(p), cached[1]], capture_output=True, text=True,
                             timeout=300, env=env, cwd=tmp_path)
        assert (run.returncode, run.stdout.split()) == (0, ["1", "True"]), run.stdout + run.stderr


def _program() -> str:
    """The installed ``odsuite`` program beside this interpreter."""
    import os

    path = os.path.join(os.path.dirname(sys.executable), "odsuite")
    assert os.access(path, os.X_OK), path
    return path


def test_a_summary_command_ends_without_the_teardown_as_it_would_with_it(tmp_path, capsys):
    """``info``, ``history`` and ``model`` end the program in ``main`` once their output is flushed
    (freeing every module costs them a tenth of their time): what they print, their exit codes and
    their one-line errors are those of the same command run in-process; a reader that stops early
    gets no traceback."""
    import json
    import subprocess

    p = tmp_path / "p.h5"
    for argv in (["new", p], ["acquire", p, "--daq", "sim", "--name", "T1", "--scenario", "T1", "--seed", "1",
                              "--samples", "2048"], ["process", p]):
        assert main([str(a) for a in argv]) == 0
    capsys.readouterr()
    for argv in (["info", str(p)], ["info", str(p), "--json"], ["history", str(p), "--json"],
                 ["model", str(p), "--json"], ["info", str(tmp_path / "missing.h5")]):
        code = main(argv)
        in_process = capsys.readouterr()
        run = subprocess.run([_program(), *argv], capture_output=True, text=True, timeout=300, cwd=tmp_path,
                             env={**__import__("os").environ, "COLUMNS": str(app_module.console_width())})
        assert run.returncode == code, (argv, run.stderr)
        if argv[-1] == "--json":
            assert json.loads(run.stdout) == json.loads(in_process.out), argv
        elif code == 0:
            assert "model revisions" in run.stdout and run.stdout == in_process.out
        else:
            assert run.stdout == "" and run.stderr.splitlines() == [f"error: {tmp_path / 'missing.h5'}: no such project file"]
    # a reader that closes the pipe after a few bytes: no traceback, the writer's usual ending
    reader = subprocess.run(f"'{_program()}' info '{p}' --json | head -c 10", shell=True, capture_output=True,
                            text=True, timeout=300, cwd=tmp_path)
    assert reader.stdout == json.dumps({"path": str(p)})[:10] and "Traceback" not in reader.stderr

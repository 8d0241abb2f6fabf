"""The ``odsuite`` command line: every command is a thin call into the Python API.

Only ``OdsuiteError`` is caught: it is printed as one line and the exit code is 1. Any other
exception is a bug and keeps its traceback. Ctrl-C ends a command with exit code 130 and one line
saying what was stored and what was not.

Names and paths are data: every string printed goes through ``shown`` (no rich markup, control
characters and undecodable bytes escaped), so a name like ``[/x]`` or ``x\\xff`` prints as itself.
"""

from __future__ import annotations

import copy
import functools
import gc
import os
import signal
import sys
import threading
from pathlib import Path

#: Ctrl-Cs received: one while the command line loads (imports take about a second) is held here
#: until ``main`` can report it (only when run as the ``odsuite`` program, never for an importing
#: library); one swallowed on the way (see ``_unraisable``) is reported when the command ends.
_INTERRUPTS: list[int] = []

_AS_PROGRAM = Path(sys.argv[0]).name == "odsuite"

if _AS_PROGRAM:
    signal.signal(signal.SIGINT, lambda signum, frame: _INTERRUPTS.append(signum))
    signal.signal(signal.SIGTERM, lambda signum, frame: _INTERRUPTS.append(signum))
    # start-up makes objects that live as long as the program: collecting cycles among them is
    # wasted work (some 30 ms of CPU); on again, with them frozen, when the command runs
    gc.disable()

#: a command that reads and summarises, writing no file
_SUMMARY = (_AS_PROGRAM and sys.argv[1:2] in (["info"], ["history"], ["model"])
            and not any(a.startswith("--figure") for a in sys.argv))

if _SUMMARY:
    # numpy's OpenBLAS starts without worker threads (unless the user set a count), as a worker
    # spins about 0.1 s of CPU once numpy loads, which a shared machine takes from the command itself
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import typer

from odsuite.contracts.interrupts import said_on_interrupt, say_on_interrupt
from odsuite.domain.display import fixed
from odsuite.domain.errors import ConfigError, OdsuiteError
from odsuite.store import diskspace
from odsuite.cli.printable import shown  # noqa: F401  (commands import it from here)

app = typer.Typer(
    name="odsuite",
    help="Experimental vibration analysis: impact tests, rigid-plate motion, model comparison.",
    no_args_is_help=True,
    add_completion=True,  # --install-completion / --show-completion for bash, zsh, fish, PowerShell
    pretty_exceptions_enable=False,
)


def echo_force_point(project, name: str, written: str | None) -> None:
    """The force point experiment ``name`` stored, in mm with the body hit, when the command line
    gave one: a bare number's unit (mm) said back."""
    from odsuite.domain.excitation import read_force_point
    from odsuite.store.project import open_project

    if written is None:
        return
    with open_project(project) as p:
        if name not in p.experiment_names():  # an import that is not a record (a UFF's shapes)
            return
        exc = p.experiment(name).excitation
        body = None if p.rig is None or exc is None else exc.body or p.rig.force_body(exc.point)
    if exc is None:
        return
    mm = ", ".join(f"{1e3 * v:.4g}" for v in exc.point)
    console.print(f"force point ({mm}) mm in the rig frame" + (", read from bare numbers as mm"
                  if read_force_point(written)[1] else "") + (f", on {body!r}" if body else ""),
                  highlight=False, soft_wrap=True)


class _LazyConsole:
    """rich's console, made when a command first uses it (a command printing plain text, ``info``,
    never imports rich): this object then becomes ``rich_console.DataConsole`` itself, so every
    reference to it (imported by name, monkeypatched, given to rich) is the console."""

    def __init__(self, **kwargs) -> None:
        object.__setattr__(self, "_kwargs", kwargs)

    def _become(self) -> None:
        from odsuite.cli.rich_console import DataConsole

        kwargs = self.__dict__.pop("_kwargs")
        object.__setattr__(self, "__class__", DataConsole)
        DataConsole.__init__(self, **kwargs)

    def __getattr__(self, name: str):
        if name == "_kwargs":  # looked up while becoming: not there
            raise AttributeError(name)
        self._become()
        return getattr(self, name)

    def __setattr__(self, name: str, value) -> None:
        self._become()
        setattr(self, name, value)

console = _LazyConsole()

err_console = _LazyConsole(stderr=True)


def console_width() -> int:
    """The width tables are laid out in: the console's once made (tests set it), else what rich
    would take: $COLUMNS, the terminal's, 80 when piped."""
    import shutil

    return shutil.get_terminal_size((80, 24)).columns if isinstance(console, _LazyConsole) else console.width


def wrapped(text: str) -> list[str]:
    """``text`` (user data included: it goes through ``shown``) as lines wrapped at its spaces to
    the console's width, each continuation line indented two spaces past its line's own indent; a
    word longer than a line (a path) stays whole on its own line. A line break in ``text`` (a
    message of several lines quoted in a note) starts a line of its own, wrapped alike: ``shown``
    would print it as the two characters of its escape."""
    import textwrap

    out = []
    for part in str(text).split("\n"):
        part = shown(part.rstrip("\r"))
        indent = part[:len(part) - len(part.lstrip(" "))]
        out += textwrap.wrap(part.strip(" "), console_width(), initial_indent=indent, subsequent_indent=indent + "  ",
                             break_long_words=False, break_on_hyphens=False) or [""]
    return out


def paragraph(text: str, out=None, *, style: str | None = None) -> None:
    """``text`` printed on ``out`` (the console) as :func:`wrapped` lines."""
    for line in wrapped(text):
        # a line each: the console shows a line break inside a string as the escape it is in data
        (console if out is None else out).print(line, style=style, highlight=False, soft_wrap=True)


class _Interrupted(BaseException):
    """Ctrl-C, raised instead of KeyboardInterrupt so click does not turn it into 'Aborted!'; every
    ``finally`` and copy-on-write cleanup still runs."""


def _commits() -> list[Path]:
    """``storage.COMMITS`` without importing storage: a Ctrl-C that cut an import short (numpy's)
    makes importing it again fail, and before storage is imported nothing was committed."""
    return getattr(sys.modules.get("odsuite.store.storage"), "COMMITS", [])


class _Ledger:
    """What the running command stored, for the one line a Ctrl-C prints. A command names the
    units it will store (``plan``), opens each (``start``) and closes it (``done``); a unit whose
    commit reached the disk (``storage.COMMITS``) before the interrupt counts as stored."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self.target: Path | None = None
        self.planned: list[str] = []
        self.stored: list[str] = []
        self.current: str | None = None
        self.commits_at_start = 0
        #: the whole line once a command's work has ended (a batch printing its table)
        self.settled: str | None = None

    def plan(self, target: Path, units: list[str]) -> None:
        self.target, self.planned, self.commits_at_start = target, list(units), len(_commits())

    def start(self, unit: str) -> None:
        self.current, self.commits_at_start = unit, len(_commits())

    def done(self) -> None:
        if self.current is not None:
            self.stored.append(self.current)
        self.current = None

    def settle(self, line: str) -> None:
        self.settled = line

    def line(self) -> str:
        if self.settled is not None:
            return self.settled
        if said_on_interrupt() is not None:  # a plugin's command knows what it wrote
            return said_on_interrupt()
        if self.current is not None and len(_commits()) > self.commits_at_start:
            self.done()
        if self.target is None:
            return "interrupted: nothing stored"
        missing = [u for u in self.planned if u not in self.stored]
        if not self.stored:
            return f"interrupted: nothing stored, {self.target} unchanged"
        return (f"interrupted: stored {', '.join(self.stored)} in {self.target}; not stored: "
                f"{', '.join(missing) or 'nothing'}")

    def after_error(self, message: str) -> str:
        """The error line of a command that failed after committing some units (multi-experiment
        ``process``): it names what stays stored."""
        if self.current is not None and len(_commits()) > self.commits_at_start:
            self.done()
        if not self.stored:
            return message
        missing = [u for u in self.planned if u not in self.stored]
        return (f"{message.removesuffix('; project unchanged')}; stored before the error: "
                f"{', '.join(self.stored)} in {self.target}; not stored: {', '.join(missing) or 'nothing'}")

_ledger = _Ledger()


def _print_version(value: bool) -> None:
    if value:
        from odsuite.domain.version import __version__

        console.print(f"odsuite {__version__}", highlight=False)
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", callback=_print_version, is_eager=True,
                                 help="Print odsuite's version and exit."),
) -> None:
    """Experimental vibration analysis: impact tests, rigid-plate motion, model comparison."""
    from odsuite.contracts.plugins import default_manager, registries

    # every provider is checked against its contract before any command runs
    registries()
    for line in default_manager().failures.values():  # left out, the rest runs on
        err_console.print(f"note: {line}", highlight=False, soft_wrap=True)


def _rendered_doc(renderer, res) -> dict:
    """What a renderer wrote, for --json: the files (a movie may fall back to another format)."""
    return {"renderer": renderer.name, "outputs": [{"path": str(res.path), "bytes": res.path.stat().st_size}],
            "summary": res.summary, "notes": list(res.notes)}


def _figure_renderer(name: str, output: Path, project: Path, option: str):
    """The registered figure renderer ``name``, checked to write ``output`` (before any work)."""
    from odsuite.contracts.plugins import registries
    from odsuite.contracts.renderers import choose_renderer

    _check_output(output, project, option)
    registry = registries().renderers
    suffixes = registry.get(name).suffixes if name in registry else ()
    if suffixes and output.suffix.lower() not in suffixes:
        words = f"{', '.join(suffixes[:-1])} or {suffixes[-1]}" if len(suffixes) > 1 else suffixes[0]
        raise ConfigError(f"{option} {output}: suffix {output.suffix!r} is not {words}")
    return choose_renderer(registry, output, name, "figure")

#: Output files of the running command, checked before writing, and whether each existed then:
#: a full disk names the last one and removes the new ones (a writer that ran into it half-way).
_OUTPUTS: dict[Path, bool] = {}


def _check_output(output: Path, project: Path, option: str) -> None:
    from odsuite.store.storage import check_output

    output = check_output(output, project, option)
    _OUTPUTS[output] = output.exists() or output.is_symlink()


def _print_json(doc) -> None:
    """Exactly one JSON document on stdout (NaN/inf become null, which JSON lacks)."""
    import json
    import math

    def clean(x):
        if isinstance(x, float) and not math.isfinite(x):
            return None
        if isinstance(x, (bytes, bytearray, memoryview)):  # SQLite BLOBs: hexadecimal text
            return bytes(x).hex()
        if isinstance(x, dict):
            return {str(k): clean(v) for k, v in x.items()}
        if isinstance(x, (list, tuple)):
            return [clean(v) for v in x]
        return x

    print(json.dumps(clean(doc)))


def _loop_progress():
    from rich.progress import BarColumn, Progress, TextColumn

    return Progress(TextColumn("{task.description}"), BarColumn(), console=err_console, transient=True,
                    disable=not err_console.is_terminal)


def _modal_table(rows) -> Table:
    """compare's measured-against-model modes: frequencies (Hz), damping ratios (%), MAC."""
    from rich.table import Table

    table = Table(title="measured against model modes (-: no model mode within 10 %)")
    cells = []
    for r in rows:
        paired = r["model_hz"] is not None
        cells.append([r["experiment"], f"{r['measured_hz']:.2f}", f"{r['model_hz']:.2f}" if paired else "-",
                      f"{100 * (r['model_hz'] / r['measured_hz'] - 1):+.2f}%" if paired else "-",
                      fixed(100 * r["measured_zeta"], 3), fixed(100 * r["model_zeta"], 3) if paired else "-",
                      f"{100 * (r['model_zeta'] / r['measured_zeta'] - 1):+.0f}%" if paired and r["measured_zeta"] else "-",
                      "-" if r["mac"] is None else f"{r['mac']:.3f}"])
    table.add_column("record", no_wrap=True)
    # a narrow terminal wraps the headers, never cuts a number ("0.7…" for a MAC of 0.766)
    for k, col in enumerate(("meas. Hz", "model Hz", "Δf", "meas. ζ %", "model ζ %", "Δζ", "MAC"), start=1):
        table.add_column(col, min_width=max((len(c[k]) for c in cells), default=1))
    for c in cells:
        table.add_row(*c)
    return table


def _register_plugin_commands() -> None:
    from odsuite.contracts.plugins import default_manager

    default_manager().hook.odsuite_register_commands(app=app)


def _commands_for(args: list[str]) -> typer.Typer:
    """The app click's commands are built from: when the line starts with a command's name, that
    command alone (building all of them costs a start-up more than ``info`` itself); the whole app
    for anything else (``--help``, a misspelt name's suggestions, shell completion)."""
    named = [c for c in app.registered_commands
             if args and (c.name or typer.main.get_command_name(c.callback.__name__)) == args[0]]
    if not named:
        return app
    narrowed = copy.copy(app)
    # a name registered again (a plugin's, by ``main`` run twice in one process): click keeps the last
    narrowed.registered_commands = named[-1:]
    return narrowed


def _quiet_flags(command) -> None:
    """On/off flags take no value, so their help shows no type: an empty metavar drops typer's
    ``<bool>`` (the help option included, which click makes once per command and caches)."""
    # the command's own Context class: typer carries its own click, a second one costs an import
    command.get_help_option(command.context_class(command))
    for param in [*command.params, command._help_option]:
        if getattr(param, "is_flag", False):
            param.metavar = ""
    for sub in getattr(command, "commands", {}).values():
        _quiet_flags(sub)


class _NoDigitGroups:
    """Mixed into click's int and float types: ``1_000`` is refused, as data files refuse it
    (Python's int() and float() read it as 1000)."""

    def convert(self, value, param, ctx):
        if isinstance(value, str) and "_" in value:
            import reprlib

            raise ConfigError(f"{max(param.opts, key=len)}: expected a number without digit groups ('_'), "
                              f"got {reprlib.repr(value)}")
        return super().convert(value, param, ctx)


@functools.cache
def _without_digit_groups(number_type: type) -> type:
    return type(number_type.__name__, (_NoDigitGroups, number_type), {})


def _plain_numbers(command) -> None:
    """Every int and float option and argument of ``command`` and its subcommands refuses digit
    groups (``_NoDigitGroups``); one place for the options of every command, plugins' included."""
    for param in command.params:
        # by name: typer brings its own click (as for ClickException in _failed)
        if {c.__name__ for c in type(param.type).__mro__} & {"IntParamType", "FloatParamType"} \
                and not isinstance(param.type, _NoDigitGroups):
            param.type = copy.copy(param.type)  # click's INT and FLOAT are shared: left as they are
            param.type.__class__ = _without_digit_groups(type(param.type))
    for sub in getattr(command, "commands", {}).values():
        _plain_numbers(sub)


def _on_interrupt(signum, frame) -> None:
    # one interrupt ends the command; further ones wait for its cleanup (temporary copies, workers)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    _INTERRUPTS.append(signum)
    raise _Interrupted()


def _unraisable(hook_args) -> None:
    # an interrupt raised where Python cannot raise (a finaliser) is still reported by main
    if not isinstance(hook_args.exc_value, _Interrupted):
        sys.__unraisablehook__(hook_args)


def _thread_failed(previous, hook_args) -> None:
    # a thread that fails after the command's interrupt fails because of it (a process pool's
    # manager thread setting a cancelled future's exception when its workers ended: CPython's
    # InvalidStateError, 1 of 30 interrupted diagnoses): the interrupt's line says what happened
    if not _INTERRUPTS:
        previous(hook_args)


def main(argv: list[str] | None = None) -> int:
    code = _main(argv)
    if _SUMMARY:
        _exit_now(code)
    return code


def _exit_now(code: int) -> None:
    """End the program without the interpreter's teardown: freeing every module and object costs
    a summary command about a tenth of its time, and it has closed its files and written no other.
    The exit handlers run and the output is flushed first, as the interpreter's exit would."""
    import atexit

    atexit._run_exitfuncs()  # the interpreter's own exit runs these: logging, h5py
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except (BrokenPipeError, OSError):
        code = code or 120  # what the interpreter exits with when flushing its streams fails
    os._exit(int(code or 0))


def _main(argv: list[str] | None) -> int:
    _ledger.reset()
    say_on_interrupt(None)
    _OUTPUTS.clear()
    if not _AS_PROGRAM:  # called again in the same process (tests, scripts): a fresh start
        _INTERRUPTS.clear()
    try:  # SIGTERM (kill, service managers) is answered like Ctrl-C
        previous = {s: signal.signal(s, _on_interrupt) for s in (signal.SIGINT, signal.SIGTERM)}
    except ValueError:  # not the main thread: interrupts stay Python's
        previous = None
    hook, sys.unraisablehook = sys.unraisablehook, _unraisable
    thread_hook = threading.excepthook
    threading.excepthook = functools.partial(_thread_failed, thread_hook)
    try:
        return _run(argv)
    finally:
        _collect_from_now()
        sys.unraisablehook = hook
        if not _AS_PROGRAM:  # the program's own threads may fail as it exits, after its line
            threading.excepthook = thread_hook
        if previous is not None:
            # the program's work is done: a late Ctrl-C must not kill the exiting interpreter
            for s, handler in previous.items():
                signal.signal(s, signal.SIG_IGN if _AS_PROGRAM else handler)


def _run(argv: list[str] | None) -> int:
    global _AS_JSON
    # "--json=1" is a usage error, which a script that asked for JSON still reads as JSON
    _AS_JSON = any(a == "--json" or a.startswith("--json=") for a in (sys.argv[1:] if argv is None else argv))
    try:
        if _INTERRUPTS:  # Ctrl-C while the program loaded
            raise _Interrupted()
        if (sys.argv[1:] if argv is None else argv) != ["--version"]:  # the version needs no plugin
            _register_plugin_commands()
        command = typer.main.get_command(_commands_for(sys.argv[1:] if argv is None else argv))
        _quiet_flags(command)
        _plain_numbers(command)
        _collect_from_now()
        code = command.main(args=argv, standalone_mode=False, prog_name="odsuite")
    except (_Interrupted, KeyboardInterrupt) as exc:
        err_console.print(_interrupted_line(exc), highlight=False, soft_wrap=True)
        return _interrupted_code()
    except Exception:
        if not _INTERRUPTS:
            return _failed(sys.exc_info()[1])
        # the interrupt came first and the error is its doing: a library that turned it into
        # its own error (VTK's importer reports an interrupted import as an ImportError)
        err_console.print(_interrupted_line(), highlight=False, soft_wrap=True)
        return _interrupted_code()
    if _INTERRUPTS:  # the interrupt was swallowed on the way (see _unraisable): report it
        err_console.print(_interrupted_line(), highlight=False, soft_wrap=True)
        return _interrupted_code()
    # standalone_mode=False returns a command's typer.Exit code instead of raising it
    return code if isinstance(code, int) else 0


def _collect_from_now() -> None:
    """The garbage collector on again (see ``_AS_PROGRAM``), the start-up's objects left out of it;
    left off for a summary command (``_SUMMARY``), whose objects all live until its end, which
    comes at once (``_exit_now``): collecting cycles among them cost info a tenth of its time."""
    if not gc.isenabled() and _AS_PROGRAM and not _SUMMARY:
        gc.freeze()
        gc.enable()


def _interrupted_line(exc: BaseException | None = None) -> str:
    """The ledger's line, or the one an interrupted engine made (a batch names the projects that
    changed); 'terminated (SIGTERM)' in place of 'interrupted' after SIGTERM."""
    line = getattr(exc, "line", None) or _ledger.line()
    if signal.SIGTERM in _INTERRUPTS and signal.SIGINT not in _INTERRUPTS and line.startswith("interrupted"):
        line = "terminated (SIGTERM)" + line[len("interrupted"):]
    return line


def _interrupted_code() -> int:
    """128 + the signal: 130 after Ctrl-C, 143 after SIGTERM."""
    return 128 + (signal.SIGINT if signal.SIGINT in _INTERRUPTS or not _INTERRUPTS else signal.SIGTERM)

#: the command line asked for --json: its failure is a JSON document as well
_AS_JSON = False


def _failed(exc: Exception) -> int:
    """The exit code of a command that raised ``exc`` (printing its one line), or ``exc`` again
    when it is a bug."""
    # typer brings its own click: its usage errors share typer.BadParameter's base class
    click_exception = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "ClickException")

    try:
        raise exc
    except OdsuiteError as exc:
        line = _ledger.after_error(str(exc))
        err_console.print(f"error: {line}", style="bold red", highlight=False, soft_wrap=True)
        if _AS_JSON:  # a script reading stdout gets its one document too
            _print_json({"error": line})
        return 1
    except MemoryError:
        # the memory ran out past the command's own checks (another program took it meanwhile):
        # a state of the machine, not a bug
        from odsuite.domain.memory import free_memory

        free = free_memory()
        now = "" if free is None else f" ({free / 2**20:.0f} MiB free now)"
        line = _ledger.after_error(f"out of memory{now}: close other programs, or give the command less to hold at "
                                   "once; project unchanged")
        err_console.print(f"error: {line}", style="bold red", highlight=False, soft_wrap=True)
        if _AS_JSON:
            _print_json({"error": line})
        return 1
    except typer.Exit as exc:
        return exc.exit_code
    except typer.Abort:
        err_console.print("aborted")
        return 1
    except click_exception as exc:
        # usage errors (unknown option, missing argument, a value out of range): one line like every
        # other error, the JSON document under --json, and click's own exit code (2)
        line = exc.format_message()
        ctx = getattr(exc, "ctx", None)
        where = f" (odsuite {ctx.command_path.split(' ', 1)[-1]} --help)" if ctx is not None and " " in ctx.command_path \
            else " (odsuite --help)"
        err_console.print(f"error: {line}{where}", style="bold red", highlight=False, soft_wrap=True)
        if _AS_JSON:
            _print_json({"error": line})
        return exc.exit_code
    except Exception as exc:
        if not diskspace.is_disk_full(exc):  # anything else is a bug and keeps its traceback
            raise
        # an output file (movie, report, figure, text) ran into a full disk, or the standard output did
        named = getattr(exc, "filename", None) or ([*_OUTPUTS] or [None])[-1]
        if named is None:
            # a failed write names no file: the standard output's, or a library's own file
            line = "no space left on the device written to (the standard output, or a file odsuite does not name)"
        else:
            where = Path(named)
            line = diskspace.full_message(where, where, diskspace.written_so_far(where), outcome="nothing written")
        for output, existed in _OUTPUTS.items():
            if not existed:
                output.unlink(missing_ok=True)
        err_console.print(f"error: {line}", style="bold red", highlight=False, soft_wrap=True)
        return 1


"""The Typer apps and the error-to-exit-code wrapper every command uses."""
from __future__ import annotations

import functools
import os
import traceback
from pathlib import Path
from typing import Optional

import typer
from typer.core import TyperCommand

from bpmid import __version__
from bpmid.errors import InputError, interrupted
from bpmid.progress import set_quiet

app = typer.Typer(
    name="bpmid", no_args_is_help=True, add_completion=False, rich_markup_mode=None,
    help="Identify models of bending pneumatic muscles: relaxation fits, the VBMM, baselines, discovery, control.\n\n"
         "Start with: bpmid run   (the whole study on the shipped datasets; see the README)",
)
fit_app = typer.Typer(no_args_is_help=True, rich_markup_mode=None,
                      help="Fit model constants to logs (relaxation tests or pressure-angle runs).")
app.add_typer(fit_app, name="fit")


def _version(value: bool):
    if value:
        typer.echo(f"bpmid {__version__}")
        raise typer.Exit(0)


@app.callback()
def _root(quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress on stderr."),
          version: Optional[bool] = typer.Option(None, "--version", callback=_version, is_eager=True,
                                                 help="Print the version and exit.")):
    set_quiet(quiet)


def fail(message: str, code: int = 2):
    typer.echo(f"error: {message}", err=True)
    raise typer.Exit(code)


def interrupted_exit(signal_name: str | None):
    """End an interrupted command: terminated (143) when a SIGTERM was received, even if it reached the command as
    a plain interrupt (bpmid run's stages) or inside a compiled kernel; else Ctrl-C (130)."""
    from bpmid.io.atomic import terminated_message

    if signal_name:
        fail(terminated_message(signal_name), 143)
    fail("interrupted", 130)


class PlainUsageCommand(TyperCommand):
    """A command whose usage line names the arguments as click does (``LOG...``, ``DIR``, ``[CONFIG]``);
    typer writes required ones in braces (``{LOG}...``)."""

    def parse_args(self, ctx, args):
        # an empty value (``--out ''``) would mean the current folder for a path: no bpmid option or argument
        # takes empty text, so refuse it by name instead of writing into the working directory
        args = list(args)
        for i, tok in enumerate(args):
            if tok.startswith("--") and tok.endswith("=") and len(tok) > 3:
                ctx.fail(f"option {tok[:-1]} was given an empty value; give one (a path: a file or folder name, "
                         "e.g. --out results/)")
            if tok.strip() == "" and (i == 0 or args[i - 1] != "--"):
                prev = args[i - 1] if i > 0 and args[i - 1].startswith("-") else None
                what = f"option {prev}" if prev else "an argument"
                ctx.fail(f"{what} was given an empty value; give one (a path: a file or folder name, "
                         "e.g. --out results/)")
        return super().parse_args(ctx, args)

    def collect_usage_pieces(self, ctx):
        pieces = [self.options_metavar] if self.options_metavar else []
        for p in self.get_params(ctx):
            if getattr(p, "param_type_name", "") == "argument" and not getattr(p, "hidden", False):
                name = p.metavar or p.name.upper()
                pieces.append((name if p.required else f"[{name}]") + ("..." if p.nargs != 1 else ""))
        return pieces


def command(typer_app: typer.Typer, name: str, **kw):
    """Register ``fn`` as command ``name``; InputError -> exit 2, any other exception -> exit 1."""

    def deco(fn):
        @functools.wraps(fn)
        def wrapper(*args, **kwargs):
            from bpmid.errors import command_prints_warnings
            from bpmid.io.atomic import (Terminated, guard_inputs, sigterm_as_interrupt, terminated_message,
                                         termination_received)
            from bpmid.plots.options import figure_format_kept

            try:
                # the output discipline (bpmid.io.atomic): no input replaced, SIGTERM rolls back like Ctrl-C,
                # leftovers of a killed command in the output folder recovered first; the command prints the
                # results' warnings itself (not also as Python warnings)
                with sigterm_as_interrupt(), guard_inputs(_path_inputs(kwargs)), figure_format_kept(), \
                        command_prints_warnings():
                    _recover_outputs(kwargs)
                    return fn(*args, **kwargs)
            except Terminated as exc:
                fail(terminated_message(str(exc)), 143)
            except InputError as exc:
                fail(exc.format(), 2)
            except (typer.Exit, typer.Abort, SystemExit):
                raise
            except BrokenPipeError:
                # the reader of our stdout went away (``bpmid ... | head``): the work is done, stay quiet
                devnull = os.open(os.devnull, os.O_WRONLY)
                os.dup2(devnull, 1)
                raise typer.Exit(0)
            except KeyboardInterrupt:
                interrupted_exit(termination_received())
            except SystemError as exc:
                # Ctrl-C inside a compiled kernel surfaces as (nested) "returned a result with an exception set"
                if interrupted(exc):
                    interrupted_exit(termination_received())
                raise
            except OSError as exc:
                # the file system said no (a folder that cannot be made, no permission, disk full, read-only):
                # the user can fix it
                from bpmid.io.atomic import os_error

                fail(os_error(exc, exc.filename if exc.filename is not None else "output",
                              "read or write").format(), 2)
            except Exception as exc:  # an internal failure: say so, keep the traceback one variable away
                from bpmid.io.atomic import termination_received
                if termination_received():   # a SIGTERM that compiled code turned into an error of its own
                    fail(terminated_message(termination_received()), 143)
                if os.environ.get("BPMID_DEBUG"):
                    raise
                typer.echo(traceback.format_exc(limit=-3), err=True)
                fail(f"internal error: {type(exc).__name__}: {exc} (set BPMID_DEBUG=1 for the full traceback)", 1)

        kw.setdefault("no_args_is_help", False)
        kw.setdefault("cls", PlainUsageCommand)
        return typer_app.command(name, **kw)(wrapper)

    return deco


#: command options that name what a command writes (everything else that is a path is read)
OUTPUT_OPTIONS = ("out", "plot")


def _path_inputs(kwargs) -> list[Path]:
    """Existing files among a command's path arguments other than its outputs (they must not be replaced)."""
    found = []
    for name, v in kwargs.items():
        if name in OUTPUT_OPTIONS:
            continue
        for p in (v if isinstance(v, (list, tuple)) else [v]):
            if isinstance(p, Path) and p.is_file():
                found.append(p)
    return found


def _recover_outputs(kwargs) -> None:
    """Roll back or remove what a killed command left in (or beside) this command's output."""
    from bpmid.io.atomic import recover

    out = kwargs.get("out")
    if isinstance(out, Path) and str(out):
        recover(out if out.is_dir() else out.parent)
    elif isinstance(kwargs.get("out_dir"), Path):  # bpmid report DIR: never read a half-switched folder
        recover(kwargs["out_dir"])


def check_outputs(outputs, inputs, *, suffix: str | None = None, key: str = "--out") -> None:
    """Refuse an output that would overwrite an input, that is a folder where a file is meant, that lies in a
    folder this user may not write into, or (with ``suffix``) that has another extension. ``outputs`` and ``inputs`` are paths (missing inputs are ignored)."""
    from bpmid.io.atomic import check_writable

    ins = {Path(p).resolve(): Path(p) for p in inputs if p is not None and Path(p).exists()}
    for out in outputs:
        out = Path(out)
        check_writable(out, key)
        allowed = {suffix, ".yml"} if suffix == ".yaml" else {suffix}
        if suffix is not None and out.suffix.lower() not in allowed:
            raise InputError(f"the output must be a {suffix} file, found {out.name!r}", path=out, key=key)
        if suffix is not None and out.is_dir():
            raise InputError("the output is an existing folder; give a file name", path=out, key=key)
        if out.resolve() in ins:
            raise InputError(f"the output would overwrite the input {ins[out.resolve()]}; choose another name",
                             path=out, key=key)


def existing_files(paths: list[Path], what: str = "log") -> list[Path]:
    """Check that every path is an existing file (exit-2 message naming the first that is not)."""
    if not paths:
        raise InputError(f"no {what} files given")
    for p in paths:
        if Path(p).is_dir():
            raise InputError(f"{what} is a folder, not a file", path=p)
        if not Path(p).is_file():
            raise InputError(f"{what} file not found", path=p)
    return [Path(p) for p in paths]


def spread_multi(args: list[str], options: tuple[str, ...]) -> list[str]:
    """``--train a b --test c`` -> ``--train a --train b --test c`` for the names in ``options``
    (click options take one value each; these take every value up to the next option)."""
    out, current = [], None
    for tok in args:
        if tok == "--":
            current = None
            out.append(tok)
        elif tok in options:
            current = tok
        elif tok.startswith("-") and tok != "-":
            current = None
            out.append(tok)
        elif current is not None:
            out.extend([current, tok])
        else:
            out.append(tok)
    return out


def multi_value_command(*options: str) -> type:
    """A Typer command class whose ``options`` each take every following value up to the next option."""

    class MultiValueCommand(PlainUsageCommand):
        def parse_args(self, ctx, args):
            return super().parse_args(ctx, spread_multi(list(args), options))

    MultiValueCommand.__doc__ = f"A command whose {', '.join(options)} take several values in a row."
    return MultiValueCommand

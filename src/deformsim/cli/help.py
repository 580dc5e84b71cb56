"""`--help` in words: a value option or argument shows its name as its metavar (``--out OUT``, ``DATA``), a flag
shows none, instead of Typer's internal types (``<bool>``, ``<list[Path]>``, ``{data}``); help texts are
sentences, and a docstring's paragraphs wrap to the terminal, or to :data:`HELP_WIDTH` columns in a file or pipe.
Every command also takes ``-h`` and the ``-q``/``-v`` of the whole program after its name."""

from __future__ import annotations

import contextlib
import inspect
import os
import re
import sys

import typer
from typer.core import TyperCommand, TyperGroup

HELP_WIDTH = 110  # columns of --help printed into a file or pipe (a terminal's own width otherwise)
CONTEXT = {"help_option_names": ["-h", "--help"]}


def _sentence(text: str | None, literals: set[str] = frozenset()) -> str | None:
    """A help text as a sentence: a capital first letter and a full stop. A text that starts with one of the
    option's values (``imagefolder, coco or anomalib``) or a word that is no plain word (``train.epochs``) keeps it
    as written."""
    if not text:
        return text
    first = re.match(r"[^\s,:;(]*", text).group()
    if first.isalpha() and first not in literals:
        text = f"{text[:1].upper()}{text[1:]}"
    return text if text.endswith((".", "?", "!")) else f"{text}."


def _joined(doc: str | None) -> str | None:
    """A docstring with the line breaks inside its paragraphs removed, so the terminal wraps them."""
    if doc is None:
        return None
    return "\n\n".join(" ".join(p.split()) for p in inspect.cleandoc(doc).split("\n\n"))


def _no_type(ctx=None) -> None:
    return None


def _values(param, ctx) -> set[str]:
    """The values an option completes to (its choices), none when it completes to anything."""
    if getattr(param, "_custom_shell_complete", None) is None:
        return set()
    return {item.value for item in param.shell_complete(ctx, "")}


def _name_values(params: list) -> list:
    for p in params:
        if getattr(p, "is_flag", False):
            p.metavar = ""
        elif p.metavar is None:
            p.metavar = p.name.upper().rstrip("_")
        if p.param_type_name == "argument":  # its name is shown already
            p.display_type_rich = _no_type
    return params


@contextlib.contextmanager
def _help_width():
    """Help into a file or pipe at :data:`HELP_WIDTH` columns, unless ``TERMINAL_WIDTH`` or ``COLUMNS`` says."""
    from typer import rich_utils

    before = rich_utils.MAX_WIDTH
    if before is None and not sys.stdout.isatty() and "COLUMNS" not in os.environ:
        rich_utils.MAX_WIDTH = HELP_WIDTH
    try:
        yield
    finally:
        rich_utils.MAX_WIDTH = before


QUIET_HELP = "Print warnings, errors and results only."
VERBOSE_HELP = "Also print debug lines, such as every epoch's."


def verbosity(quiet: bool, verbose: bool) -> None:
    """Show the lines that ``--quiet`` or ``--verbose`` (or neither) picks; both at once are refused."""
    from deformsim.errors import UserError
    from deformsim.log import set_verbosity

    if quiet and verbose:
        raise UserError("--quiet and --verbose exclude each other: give one")
    set_verbosity("quiet" if quiet else "verbose" if verbose else "normal")


def _remember(ctx, param, value) -> None:
    ctx.meta.setdefault("verbosity", {})[param.name] = value


def _command_verbosity() -> list:
    """``-q`` and ``-v`` as options of a command, read by :meth:`Command.invoke`."""
    flags = typer.Typer(add_completion=False)

    @flags.command()
    def options(quiet: bool = typer.Option(False, "--quiet", "-q", help=QUIET_HELP),
                verbose: bool = typer.Option(False, "--verbose", "-v", help=VERBOSE_HELP)) -> None:
        """Only their click options are used."""

    params = typer.main.get_command(flags).params
    for p in params:
        p.expose_value, p.callback = False, _remember
    return params


class _Worded:
    """Help as sentences and options shown by name, for a command or a group."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.help = _joined(self.help)

    def get_params(self, ctx):
        return _name_values(super().get_params(ctx))

    def format_help(self, ctx, formatter):
        for p in self.get_params(ctx):
            p.help = _sentence(p.help, _values(p, ctx))
        with _help_width():
            return super().format_help(ctx, formatter)


class Command(_Worded, TyperCommand):
    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.params.extend(_command_verbosity())

    def collect_usage_pieces(self, ctx) -> list[str]:
        return [re.sub(r"\{(\w+)\}", r"\1", p) for p in super().collect_usage_pieces(ctx)]

    def invoke(self, ctx):
        given = ctx.meta.pop("verbosity", {})
        if given.get("quiet") or given.get("verbose"):
            from deformsim.cli.common import fail_cleanly

            fail_cleanly(verbosity)(given["quiet"], given["verbose"])
        return super().invoke(ctx)


class Group(_Worded, TyperGroup):
    pass


def use_words(app: typer.Typer) -> None:
    """Give ``app``, its commands and its command groups the help above, ``-h`` beside ``--help`` (before the app
    first runs)."""
    app.info.cls = Group
    app.info.context_settings = {**CONTEXT, **(app.info.context_settings or {})}
    for command in app.registered_commands:
        command.cls = Command
    for group in app.registered_groups:
        use_words(group.typer_instance)

"""`--help` in words: a value option or argument shows its name as its metavar (``--out OUT``, ``DATA``), a flag
shows none, instead of Typer's internal types (``<bool>``, ``<list[Path]>``, ``{data}``); help texts are
sentences, and a docstring's paragraphs wrap to the terminal."""

from __future__ import annotations

import inspect
import re

import typer
from typer.core import TyperCommand, TyperGroup


def _sentence(text: str | None) -> str | None:
    """A help text as a sentence: a capital first letter and a full stop."""
    if not text:
        return text
    text = f"{text[:1].upper()}{text[1:]}"
    return text if text.endswith((".", "?", "!")) else f"{text}."


def _joined(doc: str | None) -> str | None:
    """A docstring with the line breaks inside its paragraphs removed, so the terminal wraps them."""
    if doc is None:
        return None
    return "\n\n".join(" ".join(p.split()) for p in inspect.cleandoc(doc).split("\n\n"))


def _no_type(ctx=None) -> None:
    return None


def _name_values(params: list) -> list:
    for p in params:
        if getattr(p, "is_flag", False):
            p.metavar = ""
        elif p.metavar is None:
            p.metavar = p.name.upper().rstrip("_")
        if p.param_type_name == "argument":  # its name is shown already
            p.display_type_rich = _no_type
        p.help = _sentence(p.help)
    return params


class _Worded:
    """Help as sentences and options shown by name, for a command or a group."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.help = _joined(self.help)

    def get_params(self, ctx):
        return _name_values(super().get_params(ctx))


class Command(_Worded, TyperCommand):
    def collect_usage_pieces(self, ctx) -> list[str]:
        return [re.sub(r"\{(\w+)\}", r"\1", p) for p in super().collect_usage_pieces(ctx)]


class Group(_Worded, TyperGroup):
    pass


def use_words(app: typer.Typer) -> None:
    """Give ``app``, its commands and its command groups the help above (before the app first runs)."""
    app.info.cls = Group
    for command in app.registered_commands:
        command.cls = Command
    for group in app.registered_groups:
        use_words(group.typer_instance)

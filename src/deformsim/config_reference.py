"""The configuration reference, written from the config models: every field's key, type, default and description.

:func:`sections` walks the config's models depth first and :func:`fields` one model's fields, each as a
:class:`FieldDoc`; :func:`markdown` renders them as ``docs/configuration.md``, rewritten by

    python -m deformsim.config_reference [PATH]    # default: docs/configuration.md, from the checkout's root
"""

from __future__ import annotations

import inspect
import re
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from types import NoneType, UnionType
from typing import Annotated, Literal, Union, get_args, get_origin

import annotated_types as at
import yaml
from pydantic import BaseModel
from pydantic.fields import FieldInfo
from pydantic_core import to_jsonable_python

from deformsim.config import Config
from deformsim.identity import Rule, rule_of
from deformsim.schema import Above, NonEmpty, Within

DOC = Path("docs/configuration.md")
_NAMES = {bool: "true or false", int: "integer", float: "number", str: "text", Path: "path"}


@dataclass(frozen=True)
class FieldDoc:
    """One config field: its dotted ``key`` (``render.surface.kinds``), the values it takes in words (``kind``),
    its ``default`` as JSON, its ``description``, the model of the section it holds (else None) and its identity
    :class:`~deformsim.identity.Rule`."""

    key: str
    kind: str
    default: object
    description: str
    section: type[BaseModel] | None
    rule: Rule


def fields(model: type[BaseModel], prefix: str = "") -> Iterator[FieldDoc]:
    """``model``'s fields in their order; ``prefix`` is the model's own dotted key (``"render.surface"``)."""
    for name, info in model.model_fields.items():
        yield FieldDoc(f"{prefix}.{name}" if prefix else name, kind(info.annotation, info.metadata),
                       to_jsonable_python(info.default), info.description or "", _section(info.annotation),
                       rule_of(model, name))


def sections(model: type[BaseModel] = Config, prefix: str = "") -> Iterator[tuple[str, type[BaseModel]]]:
    """The dotted key and model of every section under ``model``, depth first (``model`` itself not included)."""
    for f in fields(model, prefix):
        if f.section is not None:
            yield f.key, f.section
            yield from sections(f.section, f.key)


def dotted_keys(model: type[BaseModel] = Config) -> list[str]:
    """The dotted key of every field under ``model``, sections included, in :func:`sections` order."""
    return [f.key for prefix, m in [("", model), *sections(model)] for f in fields(m, prefix)]


def kind(annotation: object, metadata: tuple | list = ()) -> str:
    """The values a field of type ``annotation`` (with pydantic ``metadata``) takes, in words."""
    origin, args = get_origin(annotation), get_args(annotation)
    if origin is Annotated:
        inner = [m for a in annotation.__metadata__ for m in (a.metadata if isinstance(a, FieldInfo) else [a])]
        return kind(args[0], [*inner, *metadata])
    if origin in (Union, UnionType):
        text = " or ".join(kind(a) for a in args if a is not NoneType) + (" or null" if NoneType in args else "")
    elif origin is Literal:
        text = "one of " + ", ".join(f"`{a}`" for a in args)
    elif origin is list:
        text = f"list of {kind(args[0]).removeprefix('one of ')}"
    elif origin is tuple and args in ((float, float), (int, int)) and (args[0] is float or _ranged(metadata)):
        text = "[min, max]" + (" of integers" if args[0] is int else "")
    elif origin is tuple:
        text = "[" + ", ".join(kind(a) for a in args) + "]"
    elif isinstance(annotation, type) and issubclass(annotation, BaseModel):
        text = "section"
    else:
        text = _NAMES[annotation]
    limits = _limits(metadata)
    return f"{text} ({'; '.join(limits)})" if limits else text


def _ranged(metadata: tuple | list) -> bool:
    """A pair of integers is a range where :class:`~deformsim.schema.Within` bounds it (a float pair always is)."""
    return any(isinstance(m, Within) for m in metadata)


def _limits(metadata: tuple | list) -> list[str]:
    """What a field's metadata asks of its value, in words."""
    out = []
    low = high = None  # (bound, strict)
    for m in metadata:
        if isinstance(m, Within):
            first = f"{m.lo} ≤ min" if m.lo is not None else f"{m.above} < min" if m.above is not None else "min"
            out.append(f"{first} ≤ max" + (f" ≤ {m.hi}" if m.hi is not None else ""))
        elif isinstance(m, Above):
            out.append(f"above {m.bound}" + (f", at most {m.hi}" if m.hi is not None else ""))
        elif isinstance(m, NonEmpty) or (isinstance(m, at.MinLen) and m.min_length == 1):
            out.append("at least one")
        elif isinstance(m, at.MaxLen):
            out.append(f"at most {m.max_length}")
        elif isinstance(m, at.Ge | at.Gt):
            low = (m.ge, False) if isinstance(m, at.Ge) else (m.gt, True)
        elif isinstance(m, at.Le | at.Lt):
            high = (m.le, False) if isinstance(m, at.Le) else (m.lt, True)
    if low and high:
        out.append(f"{low[0]} {'<' if low[1] else '≤'} x {'<' if high[1] else '≤'} {high[0]}")
    elif low:
        out.append(f"{'>' if low[1] else '≥'} {low[0]}")
    elif high:
        out.append(f"{'<' if high[1] else '≤'} {high[0]}")
    return out


def _section(annotation: object) -> type[BaseModel] | None:
    """The model a field of type ``annotation`` holds (``X`` or ``X | None``), else None."""
    for t in (annotation, *get_args(annotation)):
        if isinstance(t, type) and issubclass(t, BaseModel):
            return t
    return None


def yaml_value(value: object) -> str:
    """``value`` (JSON) as one line of YAML."""
    text = yaml.safe_dump(value, default_flow_style=True, width=float("inf"), allow_unicode=True)
    return text.removesuffix("\n...\n").strip()


def commented_yaml(config: Config) -> str:
    """``config`` as a YAML file that loads back as it: every field under a comment with its description, the
    values it takes and its default."""
    return "\n".join(_yaml_lines(Config, config.model_dump(mode="json"), "", "")) + "\n"


def _yaml_lines(model: type[BaseModel], values: dict, prefix: str, pad: str) -> Iterator[str]:
    for f in fields(model, prefix):
        name, value = f.key.rpartition(".")[2], values[f.key.rpartition(".")[2]]
        if f.section is not None and isinstance(value, dict):
            yield f"{pad}# {_sentence(f.description)}"
            yield f"{pad}{yaml_value(name)}:"
            yield from _yaml_lines(f.section, value, f.key, pad + "  ")
        elif f.section is not None:  # an optional section that is off: its fields commented out, at their defaults
            yield f"{pad}# {_sentence(f.description)} To turn it on, put the commented section below in place of this null."
            yield f"{pad}{yaml_value(name)}: null"
            yield f"{pad}# {yaml_value(name)}:"
            yield from (f"{pad}# {line}" for line in _yaml_lines(f.section, f.section().model_dump(mode="json"),
                                                                  f.key, "  "))
        else:
            default = "none" if isinstance(f.default, dict) else yaml_value(f.default)
            yield f"{pad}# {_sentence(f.description)} {_sentence(f.kind.replace('`', ''))[:-1]}; default: {default}."
            yield f"{pad}{yaml_value(name)}: {yaml_value(value)}"


def _sentence(text: str) -> str:
    """``text`` with a capital first letter and a full stop."""
    return f"{text[:1].upper()}{text[1:]}."


def _prose(doc: str | None) -> str:
    """A docstring as Markdown: Sphinx roles and double backticks become code spans."""
    text = re.sub(r":\w+:`~?([^`]+)`", r"`\1`", inspect.cleandoc(doc or ""))
    return text.replace("``", "`")


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def _table(rows: Iterator[FieldDoc]) -> list[str]:
    out = ["| key | type | default | description |", "|---|---|---|---|"]
    for f in rows:
        kind_text = f.kind.replace("section", f"section [`{f.key}`](#{f.key.replace('.', '')})", 1) \
            if f.section is not None else f.kind
        default = "see the section" if isinstance(f.default, dict) else f"`{yaml_value(f.default)}`"
        note = " Not part of the dataset's identity." if f.rule.never else ""
        out.append(f"| `{f.key}` | {_cell(kind_text)} | {_cell(default)} | {_cell(f.description)}.{note} |")
    return out


def markdown() -> str:
    """The text of ``docs/configuration.md``."""
    lines = [
        "# Configuration reference",
        "",
        "Every setting with its type, default and what it does. Written from the field descriptions in",
        "`src/deformsim/config.py` by `python -m deformsim.config_reference`; edit those, not this file.",
        "",
        "A run is configured by one YAML file (the presets `quick`, the default, and `paper` are in `configs/`);",
        "every key it leaves out takes the default below. A key's dots are the YAML file's nesting:",
        "`render.surface.kinds` is `kinds` under `surface` under `render`, and the same dotted key names it in an",
        "override. A `[min, max]` range is drawn uniformly (per sample, camera or image, as its description says);",
        "null turns an optional setting off. A dataset's identity (the folder name `deformsim run` gives it, and",
        "what `deformsim generate` compares before it resumes a folder) covers every setting of `object` to",
        "`generate` except those marked as not part of it.",
        "",
        "## Sections",
        "",
        *_table(fields(Config)),
    ]
    for key, model in sections():
        lines += ["", f"## {key}", "", _prose(model.__doc__), "", *_table(fields(model, key))]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    """Write :func:`markdown` to the path given (default ``docs/configuration.md``)."""
    args = sys.argv[1:] if argv is None else argv
    path = Path(args[0]) if args else DOC
    path.write_text(markdown(), encoding="utf-8")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()

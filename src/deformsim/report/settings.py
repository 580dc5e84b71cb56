"""The report's settings section: what the data and the models were made from, and every setting that differs
from :class:`deformsim.config.Config`'s defaults, as YAML lines a user can put in a config file."""

from __future__ import annotations

from html import escape

import yaml

from deformsim.config import Config
from deformsim.evaluate.metrics_file import MetricsFile


def flatten(tree: dict, prefix: str = "") -> dict:
    """Nested mappings as dotted keys (``{"render": {"samples": 4}}`` -> ``{"render.samples": 4}``)."""
    out = {}
    for key, value in tree.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict) and value:
            out.update(flatten(value, f"{name}."))
        else:
            out[name] = value
    return out


def non_default(used: dict, defaults: dict) -> dict:
    """The dotted keys of ``used`` whose value is not the one in ``defaults`` (or that ``defaults`` lacks)."""
    flat, base = flatten(used), flatten(defaults)
    return {k: v for k, v in flat.items() if k not in base or base[k] != v}


def yaml_lines(values: dict) -> str:
    """``key: value`` lines, values in YAML (``null``, ``true``, ``[1, 2]``), or a note when there are none."""
    if not values:
        return "# every setting at its default"
    return "\n".join(f"{k}: {_flow(v)}" for k, v in values.items())


def _flow(value) -> str:
    """A value as one line of YAML."""
    return yaml.safe_dump([value], default_flow_style=True, width=10**6, allow_unicode=True).strip()[1:-1]


def _compositing(record: dict) -> dict:
    """A variant's ``composite.json`` less its name, seed and background photos' digest: its settings."""
    return {k: v for k, v in record.items() if k not in ("name", "seed", "backgrounds_digest")}


def used_settings(metrics: MetricsFile) -> dict:
    """The dataset's config (all but ``train``), each variant's compositing settings and the report's training
    settings, as one nested config."""
    data = metrics.data
    used = {k: v for k, v in (data.config or {}).items() if k not in ("train", "composite")}
    if len(data.composite) == 1:
        used["composite"] = _compositing(next(iter(data.composite.values())))
    used["train"] = metrics.settings
    return used


def settings_section(metrics: MetricsFile, extra_rows: list[tuple[str, str]]) -> str:
    """The section's HTML: ``extra_rows`` (label, HTML) after the part, spec and version rows, then the settings
    that differ from the defaults."""
    data = metrics.data
    obj = (data.config or {}).get("object") or {}
    inputs = data.inputs or {}
    part = f"mesh {obj['mesh']}" if obj.get("mesh") else "built-in soda can"
    if inputs.get("mesh"):
        part += f" (sha256 {inputs['mesh'][:16]})"
    spec = obj.get("spec") or "built-in can spec"
    if inputs.get("spec"):
        spec += f" (sha256 {inputs['spec'][:16]})"
    rows = [("part", escape(part)), ("spec", escape(spec)), ("deformsim", escape(metrics.version or "?"))]
    body = "".join(f"<tr><td>{escape(k)}</td><td>{v}</td></tr>" for k, v in rows + extra_rows)
    changed = non_default(used_settings(metrics), Config().model_dump(mode="json"))
    composites = data.composite
    per_variant = "" if len(composites) < 2 else "".join(
        f"<p class=note>composite settings of <b>{escape(v)}</b> that differ from the defaults:</p>"
        f"<pre class=yaml>{escape(yaml_lines(non_default(_compositing(c), Config().composite.model_dump(mode='json'))))}</pre>"
        for v, c in composites.items())
    return (f'<h2>Settings</h2><div class=scroll><table class="kv">{body}</table></div>'
            "<p class=note>Every setting that differs from the defaults (<code>deformsim config show</code> lists "
            f"them all), as lines for a config file:</p><pre class=yaml>{escape(yaml_lines(changed))}</pre>"
            + per_variant)

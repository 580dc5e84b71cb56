"""`deformsim generate` never mixes or silently shrinks a dataset; every failure (a full disk, a bad flag value)
is one line; SIGTERM is Ctrl-C.

Renders come from fake workers (tests/generate/fakes.py): the driver's behaviour is what is tested, without Blender.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from deformsim.config import load_config
from deformsim.dataset.layout import RENDER_KINDS
from deformsim.dataset.manifest import read_manifest
from deformsim.errors import ResourceError, UserError
from deformsim.generate.stage import generate
from tests.generate.fakes import use_fakes
from tests.util import CARTON_SPEC, ROOT, child_pids

FAKES = Path(__file__).with_name("fakes.py")


def fake_cli(*args: str, mode: str = "ok", **kw) -> subprocess.Popen:
    """``deformsim ARGS`` in a subprocess whose render workers are fakes in ``mode``."""
    env = {**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{ROOT / 'src'}", "FAKE_WORKER_MODE": mode}
    return subprocess.Popen([sys.executable, str(FAKES), *args], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kw)


def images_on_disk(out: Path) -> dict[str, int]:
    return {kind: len(list((out / "images" / kind).glob("*.png"))) for kind in RENDER_KINDS}


def binary_stl_of(first: int, triangles: int) -> bytes:
    """A binary STL whose first byte (the fake workers' shade) is ``first``."""
    return bytes([first]).ljust(80, b"\0") + triangles.to_bytes(4, "little") + b"\0" * 50 * triangles


@pytest.fixture
def carton_part(tmp_path) -> Path:
    mesh = tmp_path / "part.stl"
    mesh.write_bytes(binary_stl_of(0x10, 1))
    return mesh


def cfg_for(mesh: Path | None = None, n: int = 8, **more):
    over = {"generate.n": n, "generate.preview": 4, **more}
    if mesh is not None:
        over.update({"object.mesh": mesh, "object.spec": CARTON_SPEC})
    return load_config("quick", over)


def test_a_changed_mesh_is_refused_and_overwrite_renders_all_anew(monkeypatch, tmp_path, carton_part):
    use_fakes(monkeypatch)
    out = tmp_path / "D"
    generate(cfg_for(carton_part, 4), out, progress=False)
    carton_part.write_bytes(binary_stl_of(0x80, 3))  # same path, other part
    with pytest.raises(UserError, match="other contents of its mesh .*part.stl.*--overwrite"):
        generate(cfg_for(carton_part, 8), out, progress=False)
    assert len(read_manifest(out)) == 4  # untouched
    result = generate(cfg_for(carton_part, 8), out, progress=False, overwrite=True)
    assert result.rendered == 2  # nothing resumed from the old part
    from PIL import Image

    shades = {Image.open(out / p).getpixel((0, 0))[1] for p in read_manifest(out)["black"]}
    assert shades == {0x80}  # every image shows the new part


def test_run_settings_may_change_on_resume_and_a_counted_one_may_not(monkeypatch, tmp_path):
    use_fakes(monkeypatch)
    out = tmp_path / "D"
    generate(cfg_for(n=4), out, progress=False)
    more = cfg_for(n=8, **{"generate.workers": 2, "generate.max_retries": 0, "pose.drop_frames": 50})
    assert generate(more, out, progress=False).rendered == 1  # resumed: the settings that count are the same
    with pytest.raises(UserError, match=r"other settings \(camera.offset: None there, 0.1 now\)"):
        generate(cfg_for(n=8, **{"camera.offset": 0.1}), out, progress=False)
    with pytest.raises(UserError) as refused:  # a whole section switched on: named, its value cut short
        generate(cfg_for(n=8, **{"object.shapes": {}}), out, progress=False)
    assert re.search(r"other settings \(object.shapes: None there, \{.{10,60}\.\.\. now\)", str(refused.value))


def test_a_changed_spec_is_refused(monkeypatch, tmp_path, carton_part):
    use_fakes(monkeypatch)
    spec = tmp_path / "spec.yaml"
    spec.write_text(CARTON_SPEC.read_text())
    over = {"object.mesh": carton_part, "object.spec": spec, "generate.n": 4}
    generate(load_config("quick", over), tmp_path / "D", progress=False)
    spec.write_text(spec.read_text().replace("roughness: [0.3, 0.6]", "roughness: [0.3, 0.7]"))
    with pytest.raises(UserError, match="other contents of its spec"):
        generate(load_config("quick", {**over, "generate.n": 8}), tmp_path / "D", progress=False)


def test_a_smaller_n_is_refused_and_overwrite_leaves_no_stray_images(monkeypatch, tmp_path):
    use_fakes(monkeypatch)
    out = tmp_path / "D"
    generate(cfg_for(n=16), out, progress=False)
    with pytest.raises(UserError, match=r"holds 16 images; generate.n 8 would leave 8 of them out.*--n 16 or more"):
        generate(cfg_for(n=8), out, progress=False)
    assert len(read_manifest(out)) == 16 and images_on_disk(out) == {k: 16 for k in RENDER_KINDS}
    generate(cfg_for(n=8), out, progress=False, overwrite=True)
    assert len(read_manifest(out)) == 8 and images_on_disk(out) == {k: 8 for k in RENDER_KINDS}
    assert sorted(p.name for p in out.parent.iterdir()) == ["D"]  # nothing of the old dataset beside it
    generate(cfg_for(n=12), out, progress=False)  # a larger n still extends
    assert len(read_manifest(out)) == 12


def test_a_folder_that_is_no_dataset_is_never_used(monkeypatch, tmp_path):
    use_fakes(monkeypatch)
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("keep me")
    for overwrite in (False, True):
        with pytest.raises(UserError, match="holds files but no deformsim dataset"):
            generate(cfg_for(), tmp_path / "mine", progress=False, overwrite=overwrite)
    assert (tmp_path / "mine" / "notes.txt").read_text() == "keep me"
    (tmp_path / "file").write_text("x")
    with pytest.raises(UserError, match="is a file"):
        generate(cfg_for(), tmp_path / "file", progress=False)
    with pytest.raises(UserError, match="is a file, not a folder"):
        generate(cfg_for(), tmp_path / "file" / "under", progress=False)


def test_a_full_disk_stops_with_one_line(monkeypatch, tmp_path):
    use_fakes(monkeypatch, mode="full")
    with pytest.raises(ResourceError, match="No space left on device.*rerun the same command"):
        generate(cfg_for(), tmp_path / "D", progress=False)
    proc = fake_cli("generate", "--out", str(tmp_path / "E"), "--n", "8", "--no-progress", mode="full")
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 1, err
    assert "No space left on device" in err and "Traceback" not in err and "UnidentifiedImageError" not in err
    assert len([line for line in err.splitlines() if "error" in line]) == 1


@pytest.mark.parametrize("workers", [1, 3])
def test_a_failed_sample_is_retried_and_one_that_keeps_failing_is_recorded(monkeypatch, tmp_path, workers):
    use_fakes(monkeypatch, mode="flaky")
    out = tmp_path / "D"
    result = generate(cfg_for(n=16, **{"generate.max_retries": 2, "generate.workers": workers}), out, progress=False)
    assert result.failed == {2: "flaky sample 2"} and result.rendered == 3 and result.device == "fake"
    assert json.loads((out / "failures.json").read_text()) == {"2": "flaky sample 2"}
    assert sorted(read_manifest(out)["sample"].unique()) == [0, 1, 3]


def test_workers_that_cannot_start_stop_the_run_with_one_line(monkeypatch, tmp_path):
    use_fakes(monkeypatch, mode="nostart")
    with pytest.raises(ResourceError, match=r"^worker failed to start: .* \(see .*logs\)$"):
        generate(cfg_for(), tmp_path / "D", progress=False)


def test_flag_values_are_reported_as_flags(tmp_path):
    proc = fake_cli("generate", "--out", str(tmp_path / "D"), "--n", "-5")
    _, err = proc.communicate(timeout=120)
    text = " ".join(err.split())
    assert proc.returncode == 2 and "--n -5" in text and "quick.yaml" not in text and "Traceback" not in err, err
    assert not (tmp_path / "D").exists()


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] if Path(f"/proc/{pid}").exists() else "X"
    return state not in ("Z", "X")


def test_sigterm_stops_workers_removes_partial_files_and_says_so(tmp_path):
    out = tmp_path / "D"
    proc = fake_cli("generate", "--out", str(out), "--n", "8", "--workers", "2", "--no-progress", mode="slow")
    t0 = time.time()
    while len(list((out / "images" / "rgba").glob(".*partial*"))) < 2:  # both workers are rendering
        assert proc.poll() is None and time.time() - t0 < 60, proc.communicate()
        time.sleep(0.1)
    workers = child_pids(proc.pid)
    assert len(workers) == 2
    proc.send_signal(signal.SIGTERM)  # the driver only, as `kill PID` or a container stop does
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 143, err
    assert "terminated" in err and "rerun the same command" in err and "Traceback" not in err
    time.sleep(0.5)
    assert not any(_alive(pid) for pid in workers)
    assert not list((out / "images").rglob(".*"))  # partial renders removed


PROBED_BAD = [
    ({"size": [0.07, 0.07, float("nan")], "vertices": 8}, "has a size that is not finite"),
    ({"size": [0.1, 0.1, 0.0], "vertices": 3}, "has 3 vertices: a part needs a solid shape"),
    ({"size": [0.1, 0.1, 0.0], "vertices": 4}, "is flat (0.1 x 0.1 x 0 m)"),
    ({"size": [1e35, 1e-4, 1e-4], "vertices": 8}, "is 1e+35 x 0.0001 x 0.0001 m: a part must measure 1e-06 to"),
]


@pytest.mark.parametrize("probed, needle", PROBED_BAD, ids=["nan", "triangle", "flat", "huge"])
def test_spec_check_and_generate_refuse_the_same_meshes(monkeypatch, tmp_path, carton_part, probed, needle):
    """One function holds generate's part checks and spec check calls it too: a mesh that imports as no solid part
    (one triangle, flat, NaN vertices, absurd size) is refused by both, with the same line, before any output."""
    from deformsim.api import Engine
    from deformsim.generate import stage

    use_fakes(monkeypatch)
    monkeypatch.setattr(stage, "probe_mesh", lambda mesh, spec, timeout=300: probed)
    with pytest.raises(UserError) as by_generate:
        generate(cfg_for(carton_part, 4), tmp_path / "D", progress=False)
    with pytest.raises(UserError) as by_check:
        Engine().spec_check(CARTON_SPEC, carton_part)
    assert str(by_generate.value) == str(by_check.value) and needle in str(by_check.value)
    assert not (tmp_path / "D").exists()


def test_spec_check_refuses_a_mesh_for_a_built_in_spec_as_generate_does(monkeypatch, tmp_path, carton_part):
    from deformsim.api import Engine
    from deformsim.spec.model import BUILTIN_SPEC

    use_fakes(monkeypatch)
    with pytest.raises(UserError, match="is for the built-in can, not for mesh"):
        Engine().spec_check(BUILTIN_SPEC, carton_part)
    assert Engine().spec_check(CARTON_SPEC, carton_part).size == [0.07, 0.07, 0.19]


@pytest.mark.parametrize("command", ["generate", "run"])
def test_a_plan_past_the_limit_prints_its_estimate_and_needs_yes(monkeypatch, tmp_path, command):
    """`--n 10000000` planned for minutes and gigabytes before the first render: past CONFIRM_IMAGES images the
    plan is one line with its estimated time and disk, before any planning, unless --yes."""
    from typer.testing import CliRunner

    from deformsim import pipeline
    from deformsim.api import Engine
    from deformsim.cli.app import app
    from deformsim.config import CONFIRM_IMAGES
    from deformsim.generate import stage

    calls = []
    monkeypatch.setattr(stage, "generate", lambda cfg, out, **kw: calls.append(cfg.generate.n))
    monkeypatch.setattr(pipeline, "run", lambda cfg, out, **kw: calls.append(cfg.generate.n))
    n = CONFIRM_IMAGES + 4
    res = CliRunner().invoke(app, [command, "--out", str(tmp_path / "D"), "--n", str(n)])
    text = " ".join(res.output.split())
    assert res.exit_code == 2 and calls == [] and not (tmp_path / "D").exists(), text
    assert f"generate.n {n} is more than {CONFIRM_IMAGES} images: about" in text
    assert "hours of rendering" in text and "GB of disk; pass --yes" in text and len(text) < 300
    getattr(Engine("quick", {"generate.n": n}), command)(tmp_path / "D", yes=True)
    getattr(Engine("quick", {"generate.n": 8}), command)(tmp_path / "E")
    assert calls == [n, 8]


@pytest.mark.parametrize("seed", [str(2**64), str(2**63), "-1"])
def test_a_seed_beyond_int64_is_refused_before_any_work(tmp_path, seed):
    """`--seed` beyond 64 bits failed after rendering, with no manifest: now one line before any output."""
    proc = fake_cli("generate", "--out", str(tmp_path / "D"), "--n", "4", "--seed", seed, "--no-progress")
    _, err = proc.communicate(timeout=120)
    text = " ".join(err.split())
    assert proc.returncode == 2 and f"--seed {seed}: invalid generate.seed" in text and "Traceback" not in err, err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "D").exists()


def test_a_mesh_file_with_nan_vertices_is_refused_by_spec_check_and_generate(monkeypatch, tmp_path):
    """Blender's importer drops NaN vertices, with their faces, so the probe never sees them: the mesh file's
    numbers are read before it."""
    from deformsim.api import Engine
    from tests.spec.test_mesh_numbers import binary_stl

    use_fakes(monkeypatch)
    mesh = tmp_path / "nan.stl"
    mesh.write_bytes(binary_stl((0.0, float("nan"), 0.0)))
    for run in (lambda: generate(cfg_for(mesh, 4), tmp_path / "D", progress=False),
                lambda: Engine().spec_check(CARTON_SPEC, mesh)):
        with pytest.raises(UserError, match="nan.stl has vertex coordinates that are NaN or infinite"):
            run()
    assert not (tmp_path / "D").exists()


def test_a_spec_that_cannot_rig_a_solid_mesh_is_refused_after_the_shape_checks():
    """The probe rigs the mesh as a worker does; its rig error is the line, unless the shape itself is bad."""
    from deformsim.generate.refusals import check_probe

    rig = "spec 'part': displacement.vertex_rule selects no vertex of the mesh"
    with pytest.raises(UserError, match="vertex_rule selects no vertex"):
        check_probe(Path("m.stl"), {"size": [0.1, 0.1, 0.2], "vertices": 8, "rig": rig})
    with pytest.raises(UserError, match="is flat"):
        check_probe(Path("m.stl"), {"size": [0.1, 0.1, 0.0], "vertices": 8, "rig": rig})
    assert check_probe(Path("m.stl"), {"size": [0.1, 0.1, 0.2], "vertices": 8}) == [0.1, 0.1, 0.2]


def test_a_dataset_is_never_written_inside_a_folder_of_photos_it_reads(monkeypatch, tmp_path):
    """Its renders would be drawn as artwork (or textures) by the next run: refused before any work."""
    from PIL import Image

    use_fakes(monkeypatch)
    art = tmp_path / "art"
    art.mkdir()
    Image.new("RGB", (8, 8), (200, 30, 30)).save(art / "a.png")
    cfg = cfg_for(**{"render.appearance": {"photos": art}})
    with pytest.raises(UserError, match="--out .*art/data is or lies inside the artwork photo folder"):
        generate(cfg, art / "data", progress=False)
    assert sorted(p.name for p in art.iterdir()) == ["a.png"]


def test_overwrite_never_removes_an_output_kept_inside_the_dataset(monkeypatch, tmp_path):
    """`generate --out DATA --overwrite` removed a model and a report kept in DATA (docs/identity.md: never)."""
    use_fakes(monkeypatch)
    out = tmp_path / "D"
    generate(cfg_for(n=16), out, progress=False)
    for name, kind in (("mymodel", "model"), ("rep", "report")):  # as an older deformsim let train and report make
        (out / name).mkdir()
        (out / name / "inputs.json").write_text(f'{{"kind": "{kind}"}}')
    with pytest.raises(UserError, match=rf"holds the deformsim model {out / 'mymodel'}, which replacing it would "
                                        "remove: move that out first"):
        generate(cfg_for(n=8), out, progress=False, overwrite=True)
    assert len(read_manifest(out)) == 16 and (out / "rep" / "inputs.json").is_file()


def test_a_second_generate_into_one_folder_is_refused_and_a_dead_ones_lock_taken_over(monkeypatch, tmp_path):
    """A second `generate --overwrite` into a folder another generate was writing made the first fail (sample 0 has
    no complete record): it is refused with one line naming the first, whose lock goes with it."""
    use_fakes(monkeypatch)
    out = tmp_path / "D"
    holder = subprocess.Popen([sys.executable, "-c", "import sys, time; from deformsim.outputs import locked\n"
                               f"with locked({str(out)!r}, 'generate'):\n    print('held', flush=True); time.sleep(60)"],
                              env={**os.environ, "PYTHONPATH": str(ROOT / "src")}, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline() == "held\n"
        for overwrite in (False, True):
            with pytest.raises(UserError, match=rf"--out {out} is being written by another deformsim generate "
                                                rf"\(process {holder.pid}, lock .*\.D\.lock\)"):
                generate(cfg_for(), out, progress=False, overwrite=overwrite)
    finally:
        holder.kill()
        holder.wait()
    lock = tmp_path / ".D.lock"
    assert lock.read_text() == f"{holder.pid}\n"  # killed: its lock file is left, naming a dead process
    generate(cfg_for(), out, progress=False)
    assert len(read_manifest(out)) == 8 and sorted(p.name for p in tmp_path.iterdir()) == ["D"]

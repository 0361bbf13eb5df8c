"""``pbs batch``: orbits, sweeps and scene lists on warm contexts, resume, manifest, exit
codes, and the Dask run (docs/batch.md). Real headless GL, real processes, tiny images.

Every image is checked bit for bit against ``pbs render`` of a scene file that holds the
job's camera or key value: reusing a ``Renderer`` through ``update`` must draw exactly
what a fresh one draws.
"""

from __future__ import annotations

import importlib.util
import json
import tomllib
from pathlib import Path

import pytest
import tomlkit
from PIL import Image

from app.batch.jobs import plan_jobs
from app.cli import main
from app.scene.model import Camera

SCENE = """
background = [0.02, 0.02, 0.03]
[render]
width = 80
height = 60
[camera]
position = [0.0, 1.0, 5.0]
target = [0.0, 0.0, 0.0]
[materials.red]
base_color = [0.8, 0.1, 0.1]
roughness = 0.4
[materials.grey]
base_color = [0.5, 0.5, 0.5]
roughness = 0.7
[[objects]]
shape = "sphere"
radius = 0.8
position = [-1.0, 0.0, 0.0]
material = "red"
[[objects]]
shape = "box"
size = [1.0, 1.0, 1.0]
position = [1.2, 0.0, 0.0]
material = "grey"
[[lights]]
type = "directional"
direction = [0.5, -0.6, -0.6]
intensity = 2.0
[[lights]]
type = "point"
position = [0.0, 2.0, 2.0]
intensity = 6.0
"""


@pytest.fixture
def scene(tmp_path: Path) -> Path:
    path = tmp_path / "scene.toml"
    path.write_text(SCENE, encoding="utf-8")
    return path


def _jobs(tmp_path: Path, text: str, name: str = "jobs.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def _manifest(out: Path) -> dict[str, dict]:
    lines = (out / "manifest.jsonl").read_text(encoding="utf-8").splitlines()
    return {line["job"]: line for line in map(json.loads, lines)}


def _render_with(tmp_path: Path, scene: Path, name: str, edit: dict, size: str) -> bytes:
    """``pbs render`` of ``scene`` with top-level tables replaced by ``edit``: the PNG."""
    data = tomllib.loads(scene.read_text(encoding="utf-8"))
    for key, value in edit.items():
        data[key] = value
    edited = tmp_path / f"{name}.toml"
    edited.write_text(tomlkit.dumps(data), encoding="utf-8")
    out = tmp_path / f"{name}.png"
    assert main(["render", str(edited), "-o", str(out), "--size", size, "-q"]) == 0
    return out.read_bytes()


@pytest.mark.gl
def test_orbit_two_workers_matches_render(tmp_path: Path, scene: Path) -> None:
    """4 frames at 64x64 on 2 spawned workers: each PNG equals ``pbs render`` of a scene
    file with that frame's camera, byte for byte; frame 2 (180 degrees) differs from 0."""
    jobs = _jobs(tmp_path, f'scene = "{scene.name}"\nsize = "64x64"\norbit = {{ frames = 4 }}\n')
    out = tmp_path / "out"
    assert main(["batch", str(jobs), "-o", str(out), "--workers", "2", "-q"]) == 0
    manifest = _manifest(out)
    assert sorted(manifest) == [f"frame-{k:04d}" for k in range(4)]
    assert all(line["status"] == "ok" and line["error"] is None for line in manifest.values())
    plan = plan_jobs(jobs, out)
    for job in plan.jobs:
        camera = Camera.model_validate(job.camera).model_dump(exclude_none=True)
        expected = _render_with(tmp_path, scene, job.id, {"camera": camera}, "64x64")
        assert Path(job.output).read_bytes() == expected, job.id
    frames = [Path(job.output).read_bytes() for job in plan.jobs]
    assert frames[0] != frames[2]


@pytest.mark.gl
def test_sweep_matches_render(tmp_path: Path, scene: Path) -> None:
    """A roughness range of 3 values in one process: each image is ``pbs render`` with
    that value, and the values give different images."""
    jobs = _jobs(
        tmp_path,
        f'scene = "{scene.name}"\n'
        'sweep = { key = "materials.red.roughness", start = 0.1, stop = 0.9, count = 3 }\n',
    )
    out = tmp_path / "out"
    assert main(["batch", str(jobs), "-o", str(out), "-q"]) == 0
    data = tomllib.loads(SCENE)
    images = []
    for i, value in enumerate((0.1, 0.5, 0.9)):
        materials = {**data["materials"], "red": {**data["materials"]["red"], "roughness": value}}
        expected = _render_with(tmp_path, scene, f"r{i}", {"materials": materials}, "80x60")
        images.append((out / f"sweep-{i:04d}.png").read_bytes())
        assert images[-1] == expected, value
    assert len(set(images)) == 3


@pytest.mark.gl
def test_resume_skips_valid_and_redoes_truncated(tmp_path: Path, scene: Path) -> None:
    jobs = _jobs(tmp_path, f'scene = "{scene.name}"\nsize = "48x32"\norbit = {{ frames = 3 }}\n')
    out = tmp_path / "out"
    assert main(["batch", str(jobs), "-o", str(out), "-q"]) == 0
    whole = (out / "frame-0001.png").read_bytes()
    (out / "frame-0001.png").write_bytes(whole[: len(whole) // 2])  # a killed writer's file
    assert main(["batch", str(jobs), "-o", str(out), "-q"]) == 0
    status = {job: line["status"] for job, line in _manifest(out).items()}
    assert status == {"frame-0000": "skipped", "frame-0001": "ok", "frame-0002": "skipped"}
    assert (out / "frame-0001.png").read_bytes() == whole
    # A valid PNG of another size (the job file's size changed) is not the job's output.
    jobs.write_text(f'scene = "{scene.name}"\nsize = "32x32"\norbit = {{ frames = 3 }}\n')
    assert main(["batch", str(jobs), "-o", str(out), "-q"]) == 0
    assert {line["status"] for line in _manifest(out).values()} == {"ok"}
    # An RGB PNG is not a transparent job's output (the job file's background changed),
    # and the rerun's RGBA PNGs are kept by the next resume.
    transparent = 'background = "transparent"\n'
    jobs.write_text(
        f'scene = "{scene.name}"\nsize = "32x32"\n{transparent}orbit = {{ frames = 3 }}\n'
    )
    for expected in ("ok", "skipped"):
        assert main(["batch", str(jobs), "-o", str(out), "-q"]) == 0
        assert {line["status"] for line in _manifest(out).values()} == {expected}
    with Image.open(out / "frame-0001.png") as image:
        assert image.mode == "RGBA"


@pytest.mark.gl
def test_failed_job_alone(tmp_path: Path, scene: Path, capsys: pytest.CaptureFixture) -> None:
    """A missing scene file in a scene list fails its job only: the manifest says why,
    the other scenes render, the exit code is 1 and stderr names the job."""
    jobs = _jobs(
        tmp_path, 'size = "32x24"\nscenes = ["scene.toml", "missing.toml", "scene.toml"]\n'
    )
    out = tmp_path / "out"
    assert main(["batch", str(jobs), "-o", str(out), "-q"]) == 1
    manifest = _manifest(out)
    assert [manifest[j]["status"] for j in sorted(manifest)] == ["ok", "failed", "ok"]
    error = manifest["0001-missing"]["error"]
    assert "missing.toml" in error and "\n" not in error
    assert (out / "0000-scene.png").exists() and (out / "0002-scene.png").exists()
    assert not (out / "0001-missing.png").exists()
    assert "0001-missing" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ('scene = "scene.toml"\norbit = { frames = 0 }\n', "orbit.frames"),
        ('scene = "scene.toml"\norbit = { frames = 2, speed = 1 }\n', "orbit.speed"),
        ('scene = "nowhere.toml"\norbit = { frames = 2 }\n', "scene"),
        ('scene = "scene.toml"\norbit = { frames = 2 }\nscenes = ["a.toml"]\n', "exactly one"),
        ('scene = "scene.toml"\nsize = "0x10"\norbit = { frames = 2 }\n', "size"),
        (
            'scene = "scene.toml"\n'
            'sweep = { key = "materials.red.roughness", values = [0.5, 7] }\n',
            "sweep.values[1]",
        ),
        (
            'scene = "scene.toml"\nsweep = { key = "materials.blue.roughness", values = [0.5] }\n',
            "materials.blue",
        ),
        ("orbit = [\n", "malformed TOML"),
    ],
)
def test_bad_job_file_exit_2(
    tmp_path: Path, scene: Path, capsys: pytest.CaptureFixture, text: str, key: str
) -> None:
    jobs = _jobs(tmp_path, text)
    out = tmp_path / "out"
    assert main(["batch", str(jobs), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(jobs) in err and key in err, err
    assert not out.exists()  # refused before anything ran


@pytest.mark.gl
def test_json_job_file(tmp_path: Path, scene: Path) -> None:
    jobs = _jobs(tmp_path, json.dumps({"scenes": ["scene.toml"], "size": [16, 16]}), "j.json")
    out = tmp_path / "out"
    assert main(["batch", str(jobs), "-o", str(out), "-q"]) == 0
    assert _manifest(out)["0000-scene"]["status"] == "ok"


HAVE_DASK = importlib.util.find_spec("distributed") is not None


@pytest.mark.skipif(HAVE_DASK, reason="Dask distributed is installed")
def test_dask_missing_exit_2(tmp_path: Path, scene: Path, capsys: pytest.CaptureFixture) -> None:
    jobs = _jobs(tmp_path, f'scene = "{scene.name}"\norbit = {{ frames = 2 }}\n')
    assert main(["batch", str(jobs), "-o", str(tmp_path / "o"), "--dask-local", "2"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--dask-local" in err and "distributed" in err


@pytest.mark.skipif(not HAVE_DASK, reason="needs the 'distributed' extra (Dask)")
@pytest.mark.gl
def test_dask_local_cluster(tmp_path: Path, scene: Path) -> None:
    """The orbit on a LocalCluster of 2 worker processes gives the in-process images."""
    jobs = _jobs(tmp_path, f'scene = "{scene.name}"\nsize = "32x32"\norbit = {{ frames = 4 }}\n')
    local, dask = tmp_path / "local", tmp_path / "dask"
    assert main(["batch", str(jobs), "-o", str(local), "-q"]) == 0
    assert main(["batch", str(jobs), "-o", str(dask), "--dask-local", "2", "-q"]) == 0
    assert {line["status"] for line in _manifest(dask).values()} == {"ok"}
    for k in range(4):
        name = f"frame-{k:04d}.png"
        assert (dask / name).read_bytes() == (local / name).read_bytes()


@pytest.mark.gl
def test_progress_lines_count_jobs(
    tmp_path: Path, scene: Path, capsys: pytest.CaptureFixture
) -> None:
    """Without ``-q`` each job writes a progress line (stderr is not a terminal here)
    that counts the jobs done, gives the job's own time, the rate and the time left; a
    resumed run counts skipped jobs as done without a time or rate (they did no work)."""
    jobs = _jobs(tmp_path, f'scene = "{scene.name}"\nsize = "32x32"\norbit = {{ frames = 3 }}\n')
    out = tmp_path / "out"
    assert main(["batch", str(jobs), "-o", str(out)]) == 0
    lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("[")]
    assert len(lines) == 3
    for k, line in enumerate(lines, 1):
        assert f"] {k}/3 frame-{k - 1:04d} ok (" in line
        assert "frames" not in line and "jobs/s" in line
        took = line.split(" ok (")[1].split(";")[0]
        assert took.endswith((" ms", " s")) and float(took.split()[0]) >= 0
    assert "ETA" in lines[0] and "ETA" not in lines[-1]
    assert main(["batch", str(jobs), "-o", str(out)]) == 0
    lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("[")]
    assert [ln.split(" (")[0].split("] ")[1] for ln in lines] == [
        f"{k}/3 frame-{k - 1:04d} skipped" for k in range(1, 4)
    ]
    assert all(" (total " in ln and "jobs/s" not in ln and "ETA" not in ln for ln in lines)


@pytest.mark.gl
def test_output_folder_made_with_parents(
    tmp_path: Path, scene: Path, capsys: pytest.CaptureFixture
) -> None:
    """``-o DIR`` that does not exist yet, parents included, is made (as ``pbs render``
    makes an output's folder); a ``DIR`` under a regular file is one line and exit 2."""
    jobs = _jobs(tmp_path, f'scene = "{scene.name}"\nsize = "32x32"\norbit = {{ frames = 2 }}\n')
    out = tmp_path / "new" / "deeper" / "frames"
    assert main(["batch", str(jobs), "-o", str(out), "-q"]) == 0
    assert {line["status"] for line in _manifest(out).values()} == {"ok"}
    assert (out / "frame-0001.png").is_file()
    (tmp_path / "plain").write_text("not a folder", encoding="utf-8")
    assert main(["batch", str(jobs), "-o", str(tmp_path / "plain" / "frames"), "-q"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "-o: cannot write" in err


MESHES = Path(__file__).resolve().parent.parent / "scenes" / "meshes"


@pytest.mark.gl
def test_model_file_jobs_match_pbs_render(tmp_path: Path) -> None:
    """A job file names a model file directly, as ``scene`` (an orbit, with a look) and in
    a ``scenes`` list: frame 0 and the list's image equal ``pbs render MODEL`` with the
    same options byte for byte, and the orbit's second frame shows another side."""
    model = tmp_path / "teapot.obj"
    model.write_bytes((MESHES / "teapot.obj").read_bytes())
    orbit = _jobs(
        tmp_path,
        'scene = "teapot.obj"\nsize = "64x48"\nlook = { view = "front", elevation = 10 }\n'
        "orbit = { frames = 2, degrees = 90 }\n",
        "orbit.toml",
    )
    listed = _jobs(tmp_path, 'scenes = ["teapot.obj"]\nsize = [64, 48]\n', "list.toml")
    for jobs, argv, image in (
        (orbit, ["--view", "front", "--elevation", "10"], "frame-0000.png"),
        (listed, [], "0000-teapot.png"),
    ):
        out = tmp_path / jobs.stem
        assert main(["batch", str(jobs), "-o", str(out), "-q"]) == 0
        assert all(line["status"] == "ok" for line in _manifest(out).values())
        expected = tmp_path / f"{jobs.stem}.png"
        render = ["render", str(model), "-o", str(expected), "--size", "64x48", "-q"]
        assert main([*render, *argv]) == 0
        assert (out / image).read_bytes() == expected.read_bytes(), jobs.name
    frames = [(tmp_path / "orbit" / f"frame-{k:04d}.png").read_bytes() for k in range(2)]
    assert frames[0] != frames[1]


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ('scene = "teapot.obj"\nlook = { view = "sideways" }\norbit = { frames = 1 }\n',
         "look.view"),
        ('scene = "teapot.obj"\nlook = { zoom = 2 }\norbit = { frames = 1 }\n', "look.zoom"),
        ('scene = "teapot.obj"\nlook = { env = "room.png" }\norbit = { frames = 1 }\n',
         "look.env"),
        ('scene = "teapot.obj"\nlook = { env = "../room.hdr" }\norbit = { frames = 1 }\n',
         "look.env"),
        ('scene = "teapot.obj"\nlook = { azimuth = 400 }\norbit = { frames = 1 }\n',
         "look.azimuth"),
    ],
)  # fmt: skip
def test_bad_model_look_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture, text: str, key: str
) -> None:
    """A bad ``look`` is one line naming the job file and the key, nothing rendered."""
    (tmp_path / "teapot.obj").write_bytes((MESHES / "teapot.obj").read_bytes())
    jobs = _jobs(tmp_path, text)
    out = tmp_path / "out"
    assert main(["batch", str(jobs), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(jobs) in err and key in err, err
    assert not out.exists()

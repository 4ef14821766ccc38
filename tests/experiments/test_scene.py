"""``fairaudit experiment --scene DIR --start ROOM --goals ROOM,ROOM --tolerance T``, through the command line.

Independent routes: the routes' lengths come from the navigation plug-in called directly on the area
(``delivery_scene``, as a caller of the plug-in would, not through the run), and the relative difference
(max - min) / max is worked out here; the run's log line, error message and records must show those numbers. The area folder is the
floor the run generates by default (``write_office_floor`` at 0.05 m spacing, read at 0.1 m cells), so a run on it
with the default rooms given explicitly must reproduce the default run byte for byte.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from _cli import run

pytest.importorskip("networkx")
pytest.importorskip("PIL")

from fairaudit.experiments.navigation import delivery_scene, write_office_floor  # noqa: E402

SHORTLIST = Path(__file__).resolve().parents[2] / "examples" / "tasks" / "shortlist.toml"
FAST = ("--samples", "1", "--keep", "0.7", "--no-progress", "--target", "0.5")


@pytest.fixture(scope="module")
def area(tmp_path_factory):
    """The office floor a run generates by default, written once: (folder, rooms, route lengths in metres)."""
    path = write_office_floor(tmp_path_factory.mktemp("scene"), spacing=0.05)
    scene = delivery_scene(path, start="lobby_1", goals=("office_1", "office_2"), resolution=0.1)
    return path, scene.maps.rooms, [r.length for r in scene.routes]


def _experiment(capsys, out, *argv, task="hr-delivery", samples=True):
    fast = FAST if samples else FAST[2:]  # the exact route takes no --samples
    return run(capsys, "experiment", task, "--out", out, *fast, *argv)


def _one_error(code, out, err):
    assert code == 2 and out == "", err
    assert err.startswith("fairaudit: error: ") and err.count("\n") == 1 and "Traceback" not in err, err


@pytest.mark.slow
def test_explicit_rooms_reproduce_the_default_run_and_are_recorded(area, tmp_path, capsys):
    path, _, lengths = area
    diff = (max(lengths) - min(lengths)) / max(lengths)
    assert 0 < diff < 0.01  # the two routes differ slightly on this floor
    code, _, err_default = _experiment(capsys, tmp_path / "default")
    assert code == 0, err_default
    code, _, err = _experiment(
        capsys,
        tmp_path / "given",
        *("--scene", path, "--start", "lobby_1", "--goals", "office_1,office_2", "--tolerance", "0.05"),
    )
    assert code == 0, err
    line = (
        f"fairaudit: route lengths {lengths[0]:.2f} m, {lengths[1]:.2f} m: {diff:.1%} apart, within the tolerance 5%\n"
    )
    assert err_default.startswith(line) and err.startswith(line)
    for name in ("route-1.png", "route-2.png", "kernel.csv", "candidates.csv"):
        assert (tmp_path / "default" / name).read_bytes() == (tmp_path / "given" / name).read_bytes(), name
    for folder, where in (("default", None), ("given", str(path))):
        cert = json.loads((tmp_path / folder / "certificate.json").read_text())
        header = json.loads((tmp_path / folder / "queries.jsonl").read_text().splitlines()[0])
        for scene in (cert["run"]["scene"], header["scene"]):
            assert scene["area"] == where
            assert (scene["start"], scene["goals"], scene["tolerance"]) == ("lobby_1", ["office_1", "office_2"], 0.05)
            assert scene["lengths_m"] == pytest.approx(lengths, abs=1e-12)
            assert scene["max_relative_difference"] == pytest.approx(diff, abs=1e-12)

    # resuming with other goals or another tolerance is refused, naming the flag, before a route image is rewritten
    before = (tmp_path / "given" / "route-1.png").read_bytes()
    given = ("--scene", path, "--resume")
    code, out, err = _experiment(capsys, tmp_path / "given", *given, "--goals", "office_2,office_1")
    _one_error(code, out, err)
    assert (
        "--resume: the run in" in err
        and "with other settings: --goals 'office_1,office_2', not 'office_2,office_1':" in err
    )
    code, out, err = _experiment(capsys, tmp_path / "given", *given, "--tolerance", "0.2")
    _one_error(code, out, err)
    assert "--resume: the run in" in err and "with other settings: --tolerance 0.05, not 0.2:" in err
    assert (tmp_path / "given" / "route-1.png").read_bytes() == before
    code, _, err = _experiment(capsys, tmp_path / "given", *given)  # the same rooms and tolerance (the defaults)
    assert code == 0 and "(0 now, 0 unparsed)" in err, err


@pytest.mark.slow
def test_swapped_goals_swap_the_routes(area, tmp_path, capsys):
    path, _, lengths = area
    code, _, err = _experiment(capsys, tmp_path / "o", "--scene", path, "--goals", "office_2,office_1")
    assert code == 0, err
    scene = json.loads((tmp_path / "o" / "certificate.json").read_text())["run"]["scene"]
    assert scene["goals"] == ["office_2", "office_1"]
    assert scene["lengths_m"] == pytest.approx(lengths[::-1], abs=1e-12)


@pytest.mark.slow
def test_zero_tolerance_is_refused_with_both_lengths(area, tmp_path, capsys):
    path, _, lengths = area
    code, out, err = _experiment(capsys, tmp_path / "o", "--scene", path, "--tolerance", "0")
    _one_error(code, out, err)
    assert err.startswith("fairaudit: error: --scene: the routes from lobby_1 to office_1, office_2 are not of equal")
    assert f"{lengths[0]:.2f} m, {lengths[1]:.2f} m" in err and "more than 0% (--tolerance)" in err
    assert not (tmp_path / "o").exists()  # refused before --out is made
    code, _, err = _experiment(capsys, tmp_path / "relaxed", "--scene", path, "--tolerance", "0.01")
    assert code == 0 and "within the tolerance 1%" in err, err
    assert json.loads((tmp_path / "relaxed" / "certificate.json").read_text())["run"]["scene"]["tolerance"] == 0.01


@pytest.mark.parametrize(
    "argv, field, value",
    [
        (["--goals", "office_1,boardroom_9"], "--goals", "'boardroom_9'"),
        (["--start", "atrium_1"], "--start", "'atrium_1'"),
    ],
)
def test_an_unknown_room_names_the_flag_and_lists_the_rooms(area, tmp_path, capsys, argv, field, value):
    path, rooms, _ = area
    code, out, err = _experiment(capsys, tmp_path / "o", "--scene", path, *argv)
    _one_error(code, out, err)
    assert err.startswith(f"fairaudit: error: {field}: no such room") and value in err, err
    assert all(room in err for room in rooms) and len(rooms) == 7
    assert not (tmp_path / "o").exists()


def test_a_missing_scene_folder_names_the_flag(tmp_path, capsys):
    code, out, err = _experiment(capsys, tmp_path / "o", "--scene", tmp_path / "no-such-area")
    _one_error(code, out, err)
    assert err.startswith("fairaudit: error: --scene: folder not found") and "no-such-area" in err, err
    assert not (tmp_path / "o").exists()


def test_a_room_folder_given_as_the_scene_names_the_flag(area, tmp_path, capsys):
    code, out, err = _experiment(capsys, tmp_path / "o", "--scene", area[0] / "office_1")
    _one_error(code, out, err)
    assert err.startswith("fairaudit: error: --scene: is a room folder") and "office_1" in err, err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("goals", ["office_1", "office_1,office_2,WC_1"])
def test_goals_must_give_one_room_per_candidate(area, tmp_path, capsys, goals):
    code, out, err = _experiment(capsys, tmp_path / "o", "--scene", area[0], "--goals", goals)
    _one_error(code, out, err)
    n = goals.count(",") + 1
    assert f"--goals: needs one room per candidate, in slot order: the task has 2, not {n} (got '{goals}')" in err


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--no-images", "--start", "lobby_1"], "--start: applies to the route images, and this run sends none"),
        (["--no-images", "--tolerance", "0.1"], "--tolerance: applies to the route images"),
        (["--no-images", "--scene", "floor/Area_1"], "--scene: applies to the route images, and this run sends none"),
        (
            ["--exact", "--endpoint", "http://127.0.0.1:9/v1", "--model", "m", "--goals", "a,b"],
            "--goals: the exact route reads text only",
        ),
    ],
)
def test_scene_options_without_images_are_refused(tmp_path, capsys, argv, message):
    code, out, err = _experiment(capsys, tmp_path / "o", *argv, samples="--exact" not in argv)
    _one_error(code, out, err)
    assert message in err, err


def test_a_task_file_without_a_scene_refuses_goals(tmp_path, capsys):
    code, out, err = _experiment(capsys, tmp_path / "o", "--goals", "office_1,office_2", task=SHORTLIST)
    _one_error(code, out, err)
    assert "--goals: applies to the route images, which a task file gets only with --scene" in err


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--tolerance", "1.5"], "argument --tolerance: expected a relative difference in [0, 1], got '1.5'"),
        (["--goals", "office_1,"], "argument --goals: expected comma-separated room names"),
    ],
)
def test_bad_values_are_usage_errors(tmp_path, capsys, argv, message):
    with pytest.raises(SystemExit) as exc:
        _experiment(capsys, tmp_path / "o", *argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err

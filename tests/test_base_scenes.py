"""A scene file may name a base scene (``scene = "paper2"``, or another file): it is that scene
with the file's keys set over it. Setting keys (a file over its base, or ``--set``) names them in
the description, so that a resolved scene.toml never carries a description of another scene."""

import tomllib

import pytest

from conftest import COMM, assert_refused
from rodfem.scene import SceneError, load


def _write(directory, name, text):
    path = directory / name
    if COMM.rank == 0:
        path.write_text(text)
    COMM.barrier()
    return path


def test_a_file_over_a_built_in_scene_is_that_scene_with_its_keys_set(shared_dir):
    path = _write(shared_dir, "mine.toml", 'scene = "paper2"\n[model]\nzeta = 0.7\n'
                  '[time]\nend = 2\n')
    mine, direct = load(str(path)), load("paper2", ["model.zeta=0.7", "time.end=2"])
    assert mine.sections == direct.sections
    assert mine.source == str(path)
    paper2 = load("paper2").description
    assert mine.description == f"{paper2} (with model.zeta = 0.7, time.end = 2)"
    assert mine.description == direct.description  # the same words either way


def test_a_byte_order_mark_is_not_part_of_a_file(shared_dir):
    """Some editors write one first: the scene, its base file and a sweep over it read as without
    it (tomllib alone refuses the file)."""
    base = _write(shared_dir, "base.toml", '\ufeffscene = "paper2"\n[model]\nzeta = 0.7\n')
    with pytest.raises(tomllib.TOMLDecodeError):
        tomllib.loads(base.read_text(encoding="utf-8"))
    mine = _write(shared_dir, "mine.toml", '\ufeffscene = "base.toml"\n[time]\nend = 2\n')
    direct = load("paper2", ["model.zeta=0.7", "time.end=2"])
    assert load(str(mine)).sections == direct.sections
    from rodfem.studies.sweep.design import load as load_sweep_file

    sweep = _write(shared_dir, "sweep.toml", '\ufeffscene = "mine.toml"\n[grid]\n'
                   '"mesh.cells" = [10, 20]\n')
    scenes = load_sweep_file(sweep).scenes()
    assert [s.sections for s in scenes] == [
        load("paper2", ["model.zeta=0.7", "time.end=2", f"mesh.cells={n}"]).sections
        for n in (10, 20)]


def test_set_over_a_file_over_a_base_names_each_key_once(shared_dir):
    path = _write(shared_dir, "cells.toml", 'scene = "paper2"\n[mesh]\ncells = 20\n'
                  '[output]\nprobes = [0.25, 0.5]\n')
    scene = load(str(path), ["mesh.cells=10", "time.end=0.4"])
    assert scene.description == (f'{load("paper2").description} (with mesh.cells = 10, '
                                 'output.probes = [0.25, 0.5], time.end = 0.4)')


def test_bases_chain_relative_to_each_file_and_keep_a_given_description(shared_dir):
    sub = shared_dir / "sub"
    if COMM.rank == 0:
        sub.mkdir()
    _write(sub, "base.toml", 'scene = "paper5"\ndescription = "my soft rod"\n'
           '[obstacle]\ngap = 0.2\n')
    path = _write(shared_dir, "top.toml", 'scene = "sub/base.toml"\n[obstacle]\ngap = 0.3\n'
                  '[mesh]\ncells = 40\n')
    top = load(str(path))
    expected = load("paper5", ["obstacle.gap=0.3", "mesh.cells=40"])
    assert top.sections == expected.sections
    assert top.description == "my soft rod (with obstacle.gap = 0.3, mesh.cells = 40)"
    # the resolved scene.toml stands alone: no base named, loading it gives the scene again
    resolved = tomllib.loads(top.to_toml())
    assert "scene" not in resolved
    again = _write(shared_dir, "resolved.toml", top.to_toml())
    assert load(str(again)).sections == top.sections
    assert load(str(again)).description == top.description


def test_set_names_the_keys_it_changed_or_sets_the_description():
    paper1 = load("paper1").description
    assert load("paper1", ["model.zeta=2"]).description == f"{paper1} (with model.zeta = 2)"
    # keys set over keys set: one list, each key once, at its last value
    twice = load("paper1", ["model.zeta=2", "model.k=3", "model.zeta=4"]).description
    assert twice == f"{paper1} (with model.zeta = 4, model.k = 3)"
    assert load("paper1", ["description=my rod", "model.k=3"]).description == "my rod"
    assert load("paper1").description == paper1  # nothing set, nothing added


@pytest.mark.parametrize("files, message", [
    ({"a.toml": 'scene = "b.toml"', "b.toml": 'scene = "a.toml"'},
     "its base scene 'a.toml' comes round again (a cycle of base scenes)"),
    ({"a.toml": 'scene = "a.toml"'}, "its base scene 'a.toml' comes round again"),
    ({"a.toml": 'scene = "nowhere.toml"'}, "no such file (the base scene of"),
    ({"a.toml": "scene = 3"}, 'scene must name its base scene, e.g. scene = "paper2"'),
    ({"a.toml": 'scene = "paper1"\n[model]\nzeta = -1'}, "model.zeta: must be >= 0"),
])
def test_bad_base_scenes_are_refused_in_one_line(files, message, shared_dir, capsys):
    for name, text in files.items():
        _write(shared_dir, name, text)
    with pytest.raises(SceneError, match=message.replace("(", r"\(").replace(")", r"\)")):
        load(str(shared_dir / "a.toml"))
    assert_refused(["run", str(shared_dir / "a.toml"), "--out", str(shared_dir / "out")],
                   shared_dir / "out", message, capsys)


@pytest.mark.parametrize("base, message", [
    ("link.toml", "link.toml': cannot be read (Too many levels of symbolic links)"),
    ("a\\u0000b.toml", "cannot be read (a path cannot hold a NUL character)"),
])
def test_a_base_that_is_a_loop_of_links_or_holds_a_nul_is_refused_in_one_line(
        base, message, shared_dir, capsys):
    """A base scene that is a link to itself raised RuntimeError from the path's resolution,
    one whose name holds a NUL raised ValueError: tracebacks, where the same names given as the
    scene itself were one line. A sweep over such a file is refused alike."""
    if COMM.rank == 0:
        (shared_dir / "link.toml").symlink_to("link.toml")
    _write(shared_dir, "a.toml", f'scene = "{base}"\n')
    with pytest.raises(SceneError, match=message.replace("(", r"\(").replace(")", r"\)")):
        load(str(shared_dir / "a.toml"))
    assert_refused(["run", str(shared_dir / "a.toml"), "--out", str(shared_dir / "out")],
                   shared_dir / "out", message, capsys)
    sweep = _write(shared_dir, "sweep.toml", f'scene = "{base}"\n[grid]\n"model.zeta" = [1, 2]\n')
    assert_refused(["sweep", str(sweep), "--out", str(shared_dir / "out")], shared_dir / "out",
                   message, capsys)


def test_a_sweep_over_a_file_with_a_base(shared_dir):
    from rodfem.studies.sweep.design import load as load_sweep_file

    _write(shared_dir, "mine.toml", 'scene = "paper2"\n[time]\nend = 0.5\n')
    path = _write(shared_dir, "sweep.toml", 'scene = "mine.toml"\n[grid]\n"model.k" = [1, 2]\n')
    scenes = load_sweep_file(path).scenes()
    assert [s.sections for s in scenes] == [
        load("paper2", ["time.end=0.5", f"model.k={k}"]).sections for k in (1, 2)]


def test_api_overrides_name_the_keys_they_set():
    from rodfem.api import scene_of

    paper1 = load("paper1").description
    assert scene_of("paper1", {"model.k": 3}).description == f"{paper1} (with model.k = 3)"
    assert scene_of("paper1", ["model.k=3"]).description == f"{paper1} (with model.k = 3)"


def test_api_data_may_name_a_base_scene():
    from rodfem.api import scene_of

    assert scene_of({"scene": "paper3", "model": {"k": 2}}).sections == \
        load("paper3", ["model.k=2"]).sections

"""Files at the edges: bounded regular inputs, outputs that never follow a link or lose data."""

import json
import os
import stat

import pytest

from transplanter.fileio import (
    FileRefused,
    check_output,
    commit,
    read_text_input,
    same_file,
    temp_beside,
    write_json_atomic,
)


def test_json_is_readable_by_others_and_leaves_no_temp(tmp_path):
    umask = os.umask(0o022)
    try:
        write_json_atomic(tmp_path / "r.json", {"a": 1})
    finally:
        os.umask(umask)
    assert (tmp_path / "r.json").stat().st_mode & 0o777 == 0o644
    assert json.loads((tmp_path / "r.json").read_text()) == {"a": 1}
    assert [p.name for p in tmp_path.iterdir()] == ["r.json"]


def test_replacing_keeps_the_files_mode(tmp_path):
    path = tmp_path / "r.json"
    path.write_text("{}")
    path.chmod(0o444)
    write_json_atomic(path, {"b": 2})
    assert stat.S_IMODE(path.stat().st_mode) == 0o444
    assert json.loads(path.read_text()) == {"b": 2}


def test_a_symlink_is_written_through_to_its_target_not_replaced(tmp_path):
    real = tmp_path / "real.json"
    real.write_text("old")
    link = tmp_path / "link.json"
    link.symlink_to(real)
    assert check_output(link) == real
    write_json_atomic(link, {"c": 3})
    assert link.is_symlink() and json.loads(real.read_text()) == {"c": 3}


def test_temp_files_are_new_unpredictable_and_never_a_planted_link(tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me")
    target = tmp_path / "out.rrd"
    (tmp_path / "out.rrd.tmp").symlink_to(victim)  # the old fixed temp name, planted
    a, b = temp_beside(target), temp_beside(target)
    assert a != b and a.parent == b.parent == tmp_path
    assert not a.is_symlink() and a.stat().st_size == 0
    assert victim.read_text() == "keep me"


@pytest.mark.parametrize(
    "path, needle",
    [("/dev/null", "a character device"), ("/proc/x.json", "not writable")],
)
def test_outputs_that_cannot_be_written_are_refused_up_front(path, needle):
    with pytest.raises(FileRefused, match=needle):
        check_output(path)


def test_output_checks_name_the_problem(tmp_path):
    assert check_output(tmp_path / "r.json") == tmp_path / "r.json"
    with pytest.raises(FileRefused, match="is a directory; give a file name"):
        check_output(tmp_path)
    with pytest.raises(FileRefused, match="does not exist; create it first"):
        check_output(tmp_path / "no" / "r.json")
    with pytest.raises(FileRefused, match="must end in .rrd"):
        check_output(tmp_path / "r.txt", ".rrd")
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    with pytest.raises(FileRefused, match="named pipe"):
        check_output(fifo)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pipe.json"]  # no temp left


def test_inputs_must_be_bounded_regular_files(tmp_path):
    with pytest.raises(FileRefused, match="a character device"):
        read_text_input("/dev/zero", 1000, "scenario")
    fifo = tmp_path / "pipe.toml"
    os.mkfifo(fifo)
    with pytest.raises(FileRefused, match="named pipe"):  # and does not hang
        read_text_input(fifo, 1000, "scenario")
    big = tmp_path / "big.toml"
    big.write_bytes(b"#" * 1001)
    with pytest.raises(FileRefused, match="1001 bytes; a scenario file is at most 1000"):
        read_text_input(big, 1000, "scenario")
    with pytest.raises(FileRefused, match="a directory"):
        read_text_input(tmp_path, 1000, "scenario")
    with pytest.raises(FileRefused, match="no such scenario file"):
        read_text_input(tmp_path / "none.toml", 1000, "scenario")
    text = tmp_path / "ok.toml"
    text.write_text("a = 1\n")
    assert read_text_input(text, 1000, "scenario") == "a = 1\n"


def test_a_derived_name_never_follows_a_link(tmp_path):
    """Names the program makes up (NAME.partial.rrd, a sweep's files, assets/*.stl): a link
    planted there is replaced itself, never written through; check_output refuses it."""
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me")
    link = tmp_path / "runs.csv"
    link.symlink_to(victim)
    with pytest.raises(FileRefused, match="runs.csv is a symbolic link"):
        check_output(link, derived=True)
    write_json_atomic(link, {"d": 4}, follow=False)
    assert not link.is_symlink() and json.loads(link.read_text()) == {"d": 4}
    assert victim.read_text() == "keep me"
    dangling = tmp_path / "x.partial.rrd"
    dangling.symlink_to(tmp_path / "created.txt")
    tmp = temp_beside(dangling)
    tmp.write_text("partial")
    commit(tmp, dangling, follow=False)
    assert not dangling.is_symlink() and dangling.read_text() == "partial"
    assert not (tmp_path / "created.txt").exists()
    assert dangling.stat().st_mode & 0o777 == 0o666 & ~_umask()


def _umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


def test_same_file_sees_through_links_and_hard_links(tmp_path):
    a = tmp_path / "a.toml"
    a.write_text("x")
    (tmp_path / "link").symlink_to(a)
    os.link(a, tmp_path / "hard")
    assert same_file(a, tmp_path / "link") and same_file(a, tmp_path / "hard")
    assert same_file(tmp_path / "new.json", tmp_path / "sub" / ".." / "new.json")
    assert not same_file(a, tmp_path / "b.toml")

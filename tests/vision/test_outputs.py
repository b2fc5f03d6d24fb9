"""Outputs checked before the work starts, and written all or none."""

import errno
import os

import pytest

from wiithrow.vision.errors import OutputPathError
from wiithrow.vision.outputs import (
    OutputFiles,
    StagedFile,
    check_output_file,
    check_output_folder,
    new_staging_folder,
    replace_folder,
)


def listing(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def test_a_writable_path_passes_and_nothing_is_left(tmp_path):
    assert check_output_file(tmp_path / "new" / "deeper" / "cal.json") == tmp_path / "new" / "deeper" / "cal.json"
    assert listing(tmp_path) == []


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda d: (d / "folder").mkdir() or d / "folder", "it is a folder"),
        (lambda d: (d / "file").write_text("x") and d / "file" / "cal.json", "is a file, not a folder"),
        (lambda d: (d / "file").write_text("x") and d / "file" / "a" / "b.json", "is a file, not a folder"),
    ],
)
def test_impossible_paths_are_refused_before_any_work(tmp_path, make, message):
    path = make(tmp_path)
    before = listing(tmp_path)
    with pytest.raises(OutputPathError, match=message):
        check_output_file(path)
    assert listing(tmp_path) == before


def test_a_device_is_not_replaced():
    with pytest.raises(OutputPathError, match="not a regular file"):
        check_output_file("/dev/null")


def test_an_unwritable_folder_is_refused():
    if os.access("/sys", os.W_OK) and _can_create("/sys"):
        pytest.skip("/sys accepts new files on this machine: no unwritable folder to try")
    with pytest.raises(OutputPathError, match="/sys is not writable"):
        check_output_file("/sys/cal.json")


def test_a_read_only_file_system_is_named(tmp_path, monkeypatch):
    real_open = os.open

    def read_only(path, flags, mode=0o777):
        if "wiithrow-probe" in str(path):
            raise OSError(errno.EROFS, "Read-only file system")
        return real_open(path, flags, mode)

    monkeypatch.setattr(os, "open", read_only)
    with pytest.raises(OutputPathError, match="not writable \\(a read-only file system\\)"):
        check_output_file(tmp_path / "cal.json")


def test_an_existing_file_is_kept_unless_replacing_was_asked_for(tmp_path):
    path = tmp_path / "cal.json"
    path.write_text("precious")
    with pytest.raises(OutputPathError, match="exists and would be replaced"):
        check_output_file(path, replace=False)
    with pytest.raises(OutputPathError, match="cal.json exists and --out does not name it"):
        check_output_file(path, replace=False, hint="--out does not name it")
    assert check_output_file(path, replace=True) == path
    assert path.read_text() == "precious"


def test_output_files_are_all_written(tmp_path):
    (tmp_path / "a.json").write_text("old a")
    written = OutputFiles().add(tmp_path / "a.json", "new a").add(tmp_path / "sub" / "b.csv", b"new b").commit()
    assert written == [tmp_path / "a.json", tmp_path / "sub" / "b.csv"]
    assert (tmp_path / "a.json").read_text() == "new a" and (tmp_path / "sub" / "b.csv").read_text() == "new b"
    assert listing(tmp_path) == ["a.json", "sub", "sub/b.csv"]


def test_a_failed_rename_undoes_the_others(tmp_path, monkeypatch):
    (tmp_path / "a.json").write_text("old a")
    (tmp_path / "b.csv").write_text("old b")
    real_replace = os.replace
    calls = []

    def fail_second(src, dst):
        calls.append(dst)
        if len(calls) == 2:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real_replace(src, dst)

    monkeypatch.setattr(os, "replace", fail_second)
    files = OutputFiles().add(tmp_path / "a.json", "new a").add(tmp_path / "b.csv", "new b")
    files.add(tmp_path / "new" / "c.txt", "new c")
    with pytest.raises(OSError, match="No space"):
        files.commit()
    monkeypatch.undo()
    assert (tmp_path / "a.json").read_text() == "old a" and (tmp_path / "b.csv").read_text() == "old b"
    assert listing(tmp_path) == ["a.json", "b.csv"]


def test_a_failed_write_leaves_nothing(tmp_path, monkeypatch):
    from wiithrow.vision import outputs

    real = outputs.write_temp_beside

    def fail_on_b(path, data):
        if path.name == "b.csv":
            raise OSError(errno.EIO, "Input/output error")
        return real(path, data)

    monkeypatch.setattr(outputs, "write_temp_beside", fail_on_b)
    with pytest.raises(OSError):
        OutputFiles().add(tmp_path / "a.json", "a").add(tmp_path / "x" / "b.csv", "b").commit()
    assert listing(tmp_path) == []


def test_folder_of_outputs_is_swapped_in_whole(tmp_path):
    dest = tmp_path / "out"
    dest.mkdir()
    (dest / "old.csv").write_text("old")
    staging = new_staging_folder(dest)
    (staging / "new.csv").write_text("new")
    assert listing(dest) == ["old.csv"]  # while the run works, the old folder is untouched
    replace_folder(staging, dest)
    assert listing(tmp_path) == ["out", "out/new.csv"]


def test_output_folder_checks(tmp_path):
    (tmp_path / "file").write_text("x")
    with pytest.raises(OutputPathError, match="is a file, not a folder"):
        check_output_folder(tmp_path / "file")
    with pytest.raises(OutputPathError, match="is a file, not a folder"):
        check_output_folder(tmp_path / "file" / "out")
    assert check_output_folder(tmp_path / "new" / "out") == tmp_path / "new" / "out"
    assert listing(tmp_path) == ["file"]


def _can_create(folder):
    try:
        fd = os.open(os.path.join(folder, ".wiithrow-test"), os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except OSError:
        return False
    os.close(fd)
    os.unlink(os.path.join(folder, ".wiithrow-test"))
    return True


# -- a disk that fills up -----------------------------------------------------------------------


def test_a_full_disk_keeps_the_complete_lines_written_and_says_how_many(tmp_path, monkeypatch):
    from tests.helpers.full_disk import fill_after
    from wiithrow.vision.errors import OutputWriteError

    fill_after(monkeypatch, 1000)  # 1,000 bytes: 90 lines of 11 bytes and part of the 91st
    staged = StagedFile(tmp_path / "rows.txt")
    with pytest.raises(OutputWriteError) as info:
        for i in range(10_000):
            staged.handle.write(f"row {i:06d}\n")
            staged.handle.flush()
    message = str(info.value)
    assert message == (
        f"cannot write more to {tmp_path / 'rows.txt'} (No space left on device): "
        "the 90 complete lines written until then are kept in it"
    )
    assert (tmp_path / "rows.txt").read_text().splitlines() == [f"row {i:06d}" for i in range(90)]
    staged.discard()  # what a caller's clean-up does: nothing, the lines stay
    assert [p.name for p in tmp_path.iterdir()] == ["rows.txt"]


def test_a_full_disk_found_at_commit_keeps_the_lines_too(tmp_path, monkeypatch):
    """The buffer's last block fails only when it is flushed at the end."""
    from tests.helpers.full_disk import fill_after
    from wiithrow.vision.errors import OutputWriteError

    fill_after(monkeypatch, 50)
    staged = StagedFile(tmp_path / "rows.txt")
    for i in range(10):
        staged.handle.write(f"row {i:06d}\n")  # 110 bytes, all in the buffer
    with pytest.raises(OutputWriteError, match="the 4 complete lines written until then are kept in it"):
        staged.commit()
    assert (tmp_path / "rows.txt").read_text() == "".join(f"row {i:06d}\n" for i in range(4))
    assert [p.name for p in tmp_path.iterdir()] == ["rows.txt"]


def test_whole_files_on_a_full_disk_are_one_line_and_leave_the_old_file(tmp_path, monkeypatch):
    import errno

    from wiithrow.vision import files
    from wiithrow.vision.errors import OutputWriteError

    old = tmp_path / "a.json"
    old.write_text("old")
    real_fsync = os.fsync

    def full(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(files.os, "fsync", full)
    with pytest.raises(OutputWriteError) as info:
        OutputFiles().add(old, "new").add(tmp_path / "new" / "b.json", "b").commit()
    assert (
        str(info.value)
        == f"cannot write {old} (No space left on device): nothing was written; the file there is as it was"
    )
    monkeypatch.setattr(files.os, "fsync", real_fsync)
    assert old.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["a.json"]

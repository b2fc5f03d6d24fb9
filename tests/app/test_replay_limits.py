"""A replay's memory and time are bounded by the chunk, not by the file (issue 20, item 6).

Measured in a child process, as a user runs `wiithrow replay`: its peak RSS (its own /proc VmHWM,
so neither other children nor the forking suite's size mix in) and the time the refusal takes
inside it (the interpreter's start and imports excluded, measured separately as the baseline)."""

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
import zstandard
from mcap.data_stream import RecordBuilder
from mcap.reader import make_reader
from mcap.records import Chunk, DataEnd, Footer, Header, Metadata
from mcap.writer import CompressionType, Writer

from wiithrow.app.channels import json_schemas
from wiithrow.app.cli.main import main
from wiithrow.app.recording import MAX_CHUNK_BYTES, channels
from wiithrow.app.recording.reading import MAGIC
from wiithrow.app.recording.recorder import CHUNK_BYTES

GIB = 2**30

#: Replays `argv[1]` with wiithrow's main and prints how long main took (s) on stdout's last line.
#: The child reports its own peak RSS from /proc (VmHWM: this process's address space only). Its
#: rusage would not do: Linux carries the forking parent's resident size (the suite's, 600 MB late
#: in a run) into the child's ru_maxrss across the exec.
_TIMED_REPLAY = (
    "import sys, time\n"
    "from wiithrow.app.cli.main import main\n"
    "t = time.monotonic()\n"
    "code = main(['replay', *sys.argv[1:]])\n"
    "hwm = [l for l in open('/proc/self/status') if l.startswith('VmHWM:')][0].split()[1]\n"
    "print(f'elapsed {time.monotonic() - t:.3f} {hwm}')\n"
    "sys.exit(code)\n"
)


def _measured(*args: str) -> tuple[int, str, str, float, float]:
    """Exit code, stdout, stderr, seconds inside main, and peak RSS (MB) of a child replaying."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        proc = subprocess.Popen([sys.executable, "-c", _TIMED_REPLAY, *args], stdout=out, stderr=err, text=True)
        proc.wait()
        out.seek(0)
        err.seek(0)
        stdout, stderr = out.read(), err.read()
    lines = stdout.splitlines()
    timed = lines[-1].split() if lines and lines[-1].startswith("elapsed ") else ["", "nan", "nan"]
    return proc.returncode, "\n".join(lines[:-1]), stderr, float(timed[1]), float(timed[2]) / 1024


def _metadata() -> dict[str, str]:
    metadata = {"format_version": str(channels.FORMAT_VERSION), "cameras": "2", "frame_id": "link1"}
    return metadata | {"digest": channels.digest(metadata)}


def _bomb(path: Path, chunk: Chunk) -> Path:
    """A wiithrow recording (header, metadata) whose one chunk is `chunk`."""
    builder = RecordBuilder()
    Header(profile=channels.PROFILE, library="a bomb").write(builder)
    Metadata(name=channels.METADATA_NAME, metadata=_metadata()).write(builder)
    chunk.write(builder)
    DataEnd(data_section_crc=0).write(builder)
    Footer(summary_start=0, summary_offset_start=0, summary_crc=0).write(builder)
    path.write_bytes(MAGIC + builder.end() + MAGIC)
    return path


def _chunk(data: bytes, compression: str, declared: int) -> Chunk:
    return Chunk(
        compression=compression,
        data=data,
        message_start_time=0,
        message_end_time=0,
        uncompressed_crc=0,
        uncompressed_size=declared,
    )


@pytest.fixture(scope="module")
def zeros_zstd() -> bytes:
    return zstandard.ZstdCompressor().compress(bytes(GIB))  # 1 GiB of zeros in 32 KB


@pytest.mark.parametrize("declared", [GIB, 1000], ids=["declares-1GiB", "declares-1000-bytes"])
def test_a_decompression_bomb_is_refused_in_one_line_within_bounds(tmp_path, zeros_zstd, declared):
    """A 33 KB recording whose chunk expands to 1 GiB (declaring it, or declaring 1000 bytes):
    exit 2 with one line naming the limit, within seconds inside the replay (goal: 1 s; it took
    60 s and more before) and a peak RSS under 300 MB (it was 1.24 GB), less than 100 MB above the
    interpreter with wiithrow's replay imported (the baseline, measured alike)."""
    bomb = _bomb(tmp_path / "bomb.mcap", _chunk(zeros_zstd, "zstd", declared))
    assert bomb.stat().st_size < 40_000
    code, out, err, elapsed, peak_mb = _measured(str(bomb))
    assert code == 2 and out == "" and len(err.splitlines()) == 1, err
    assert err.startswith("wiithrow replay: ") and f"{MAX_CHUNK_BYTES // 2**20} MiB" in err
    assert ("declares 1024 MiB" in err) if declared == GIB else ("expands to more than 64 MiB" in err)
    _, _, _, _, baseline_mb = _measured("--help")
    print(f"bomb: {elapsed:.3f} s, peak RSS {peak_mb:.0f} MB (baseline {baseline_mb:.0f})")
    # the time: under the 2 s once asserted on a quiet machine (goal 1 s), 2.3 s at a load of 12 on 2 cores; 15 s still tells
    # a refusal from the 60 s and more of decompressing it all (the memory bounds are the measured figures)
    assert elapsed < 15.0 and peak_mb < 300 and peak_mb - baseline_mb < 100, (elapsed, peak_mb, baseline_mb)


def test_an_lz4_bomb_is_refused_alike(tmp_path):
    """lz4, the other compression the `mcap` package reads: a chunk declaring 1000 bytes that
    expands to 256 MiB is stopped at the limit (one line, exit 2), read 1 MiB at a time."""
    import lz4.frame

    bomb = _bomb(tmp_path / "bomb.mcap", _chunk(lz4.frame.compress(bytes(256 * 2**20)), "lz4", 1000))
    assert main(["replay", str(bomb)]) == 2


def test_a_chunk_within_the_limit_that_expands_beyond_what_it_declares_is_damage(tmp_path, capsys):
    """Not a bomb (1 MiB, within the limit) but a chunk that lies about its size: the intact part
    (nothing here) is replayed and the line says where the file ends (exit 0, as for a cut file)."""
    data = zstandard.ZstdCompressor().compress(bytes(2**20))
    bomb = _bomb(tmp_path / "liar.mcap", _chunk(data, "zstd", 1000))
    assert main(["replay", str(bomb)]) == 0
    err = capsys.readouterr().err
    assert "expands to 1048576 bytes, not the 1000 it declares" in err and len(err.splitlines()) == 1


def _big_recording(small: Path, big: Path, size: int) -> int:
    """`small`'s messages written again with the recorder's chunk size and compression, with a
    session's commanded trajectories (`/arm/trajectory`: 7 joints x 1000 samples of seeded random
    floats, 64 distinct ones in turn, which the tracking replay reads and skips) among them until
    the file is `size` bytes: the rows replay unchanged. Returns the trajectories written."""
    rng = np.random.default_rng(20)
    trajectories = [
        json.dumps({"t": 0.0, "times": rng.random(1000).tolist(), "q": rng.random((1000, 7)).tolist(), "what": "p"})
        for _ in range(64)
    ]
    with small.open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        messages = [(channel.topic, m.log_time, m.data) for _, channel, m in reader.iter_messages(log_time_order=False)]
        attachments = list(reader.iter_attachments())
    written = 0
    with big.open("wb") as f:
        writer = Writer(f, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
        writer.start(profile=channels.PROFILE, library="test")
        writer.add_metadata(channels.METADATA_NAME, _metadata())
        for a in attachments:
            writer.add_attachment(a.log_time, a.create_time, a.name, a.media_type, a.data)
        ids: dict[str, int] = {}
        schemas: dict[str, int] = {}

        def channel(topic: str) -> int:
            if topic not in ids:
                name = channels.schema_of(topic)
                if name not in schemas:
                    schemas[name] = writer.register_schema(name, "jsonschema", json_schemas.schema_bytes(name))
                ids[topic] = writer.register_channel(topic, "json", schemas[name])
            return ids[topic]

        target = size // 75_000  # a trajectory compresses to about 70 KB: fewer than fill the file, the rest after

        def trajectory(log_time: int) -> None:
            nonlocal written
            text = trajectories[written % len(trajectories)].encode()
            writer.add_message(channel(channels.TRAJECTORY), log_time, text, log_time, written)
            written += 1

        for seq, (topic, log_time, data) in enumerate(messages):  # spread among the run's messages
            writer.add_message(channel(topic), log_time, data, log_time, seq)
            while written < (seq + 1) * target // len(messages):
                trajectory(log_time)
        while f.tell() < size:
            trajectory(messages[-1][1])
        writer.finish()
    assert summary is not None and written
    return written


@pytest.mark.slow
def test_a_100_mb_recording_replays_in_bounded_memory(tmp_path):
    """A 100 MB recording (a real 1.5 s run's messages among 100 MB of a session's trajectories,
    chunked as the recorder does) replays the run's rows exactly, with a peak RSS at most 25 MB
    above the same replay of the 0.1 MB run alone (the baseline: the interpreter, wiithrow's
    imports and the tracking's compiled kernels, 250-275 MB here, 210 MB of it the imports), and
    under 350 MB: holding the file, even compressed, would add 100 MB; the replay held every
    message before (920 MB for this file; a 12.9 MB recording took 593 MB)."""
    small, big = tmp_path / "run.mcap", tmp_path / "big.mcap"
    rows = tmp_path / "live.jsonl"
    assert main(["track", "--sim", "--duration", "1.5", "--seed", "3", "--record", str(small), "--out", str(rows)]) == 0
    assert _big_recording(small, big, 100 * 2**20) > 1000
    assert big.stat().st_size >= 100 * 2**20
    code, _, err, _, baseline_mb = _measured(str(small), "--out", str(tmp_path / "small.jsonl"))
    assert code == 0 and err == ""
    start = time.monotonic()
    code, _, err, elapsed, peak_mb = _measured(str(big), "--out", str(tmp_path / "big.jsonl"))
    assert code == 0 and err == "", err
    replayed = (tmp_path / "big.jsonl").read_text().splitlines()
    assert replayed == (tmp_path / "small.jsonl").read_text().splitlines() and len(replayed) > 400
    assert peak_mb - baseline_mb < 25 and peak_mb < 350, (peak_mb, baseline_mb)
    assert time.monotonic() - start < 120 and elapsed < 60
    print(
        f"replay of {big.stat().st_size / 2**20:.0f} MB: peak RSS {peak_mb:.0f} MB (baseline {baseline_mb:.0f}), {elapsed:.1f} s"
    )


def test_a_nested_message_ends_the_replay_in_one_line(tmp_path, capsys):
    """A report message nested 10,000 deep (valid JSON, a CRC that matches): `loads_json` refuses
    it in one line, no RecursionError; the replay ends there and says so (exit 0, nothing after)."""
    path = tmp_path / "nested.mcap"
    with path.open("wb") as f:
        writer = Writer(f, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
        writer.start(profile=channels.PROFILE, library="test")
        writer.add_metadata(channels.METADATA_NAME, _metadata())
        schema = writer.register_schema("wiithrow.HidReports", "jsonschema", b"{}")
        channel = writer.register_channel(channels.reports_topic(0), "json", schema)
        nested = b'{"camera": 0, "t": [1.0], "data": ' + b"[" * 10_000 + b"]" * 10_000 + b"}"
        writer.add_message(channel, 1_000_000_000, nested, 1_000_000_000, 0)
        writer.finish()
    assert main(["replay", str(path)]) == 0
    out = capsys.readouterr()
    assert out.out == "" and len(out.err.splitlines()) == 1 and "Traceback" not in out.err
    assert "a damaged /wiimote/0/reports message" in out.err and "nested deeper than 32 levels" in out.err


def test_the_dashboards_remotes_read_the_file_again_each_lap(tmp_path):
    """`replay --dashboard`'s remotes over three laps of a recording: each lap sends the camera's
    recorded IR reports again, in order, read from the file anew (a pass per lap, none kept)."""
    from wiithrow.app.recording import read_recording
    from wiithrow.app.recording.replayed_remote import ReplayedRemote, ReplayStart, recorded_ir_reports
    from wiithrow.clock import SimClock
    from wiithrow.vision.wiimote.protocol import OUT_REPORT_MODE

    path = tmp_path / "run.mcap"
    assert main(["track", "--sim", "--duration", "0.5", "--record", str(path), "--out", str(tmp_path / "r.jsonl")]) == 0
    recording = read_recording(path)
    start = ReplayStart.of(recording)
    recorded = [report for _, report in recorded_ir_reports(recording, 0)]
    assert start.end is None and start.counts[0] == len(recorded) > 40
    clock = SimClock()
    remote = ReplayedRemote(recording, 0, clock, start)
    remote.open()
    remote.write(bytes([OUT_REPORT_MODE, 0x00, 0x37]))
    assert remote.read(22, 0)[0] == 0x22  # the acknowledgement
    sent = []
    while clock.now() < 2.5 * start.period:
        clock.advance(0.005)
        while report := remote.read(22, 0):
            sent.append(report)
    remote.close()
    n = len(recorded)
    assert 2 * n < len(sent) <= 3 * n and sent[:n] == sent[n : 2 * n] == recorded
    assert sent[2 * n :] == recorded[: len(sent) - 2 * n] and remote._lap == 2

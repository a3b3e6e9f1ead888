"""Bag loading benchmark: time and peak memory of reading an MCAP file of a 7-joint arm through an experiment.

The file: ``sensor_msgs/JointState`` of 7 joints (position, velocity, effort) at 1 kHz with header stamps and
``std_msgs/Float64MultiArray`` commands of 7 values at 500 Hz, ``--seconds`` long (default 300 s: 300,000 and
150,000 messages), written by the ``mcap`` package's writer with zstd chunks (messages serialized by rosbags).
It is generated once into ``--file`` (default a temporary folder) and kept with ``--keep``. The reading runs in
a fresh Python process: :func:`symbolic.data.load` of an experiment mapping 7 positions, 7 efforts and 7
commands; the peak resident memory is read from ``/proc/self/status`` (VmHWM, reset through
``/proc/self/clear_refs`` after the imports) minus the resident memory before the call, and compared with the
file's size and with the float64 size of what is kept (the times and 21 numbers of every message read, then
the aligned signals).

``python bench/bag_load.py`` writes bench/results/bag_load.md.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
JOINTS = tuple(f"joint{k}" for k in range(1, 8))
EPOCH = 1_700_000_000_000_000_000


def generate(path: Path, seconds: float) -> tuple[int, int]:
    """The MCAP file; returns the joint states' and the commands' message counts."""
    from mcap.writer import CompressionType, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    T = store.types  # noqa: N806
    n = int(seconds * 1000) + 1
    rng = np.random.default_rng(0)
    with path.open("wb") as f:
        writer = Writer(f, compression=CompressionType.ZSTD)
        writer.start(profile="ros2", library="bench")
        ids = {}
        for topic, msgtype in (("/joint_states", "sensor_msgs/msg/JointState"),
                               ("/command", "std_msgs/msg/Float64MultiArray")):
            schema = writer.register_schema(msgtype, "ros2msg", store.generate_msgdef(msgtype, ros_version=2)[0].encode())
            ids[topic] = writer.register_channel(topic, "cdr", schema)
        layout = T["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0)
        for k in range(n):
            ns = EPOCH + k * 1_000_000
            t = k / 1000.0
            q = np.array([0.5 * np.sin(2 * np.pi * 0.2 * (j + 1) * t) for j in range(7)])
            header = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
                                              frame_id="")
            message = T["sensor_msgs/msg/JointState"](header=header, name=list(JOINTS), position=q,
                                                      velocity=q * 0.1, effort=rng.normal(0, 1, 7))
            writer.add_message(ids["/joint_states"], ns + 300_000, store.serialize_cdr(message, message.__msgtype__),
                               ns + 300_000)
            if k % 2 == 0:
                command = T["std_msgs/msg/Float64MultiArray"](layout=layout, data=q)
                writer.add_message(ids["/command"], ns, store.serialize_cdr(command, command.__msgtype__), ns)
        writer.finish()
    return n, (n + 1) // 2


def experiment(path: Path) -> Path:
    lines = [f'data = "{path.name}"', "[signals]"]
    for j, name in enumerate(JOINTS):
        lines += [f'q_{name} = "/joint_states.position[{name}]"', f'tau_{name} = "/joint_states.effort[{name}]"',
                  f'ref_{name} = "/command.data[{j}]"']
    out = path.with_suffix(".experiment.toml")
    out.write_text("\n".join(lines) + "\n")
    return out


def status(field: str) -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1]) * 1024
    raise LookupError(field)


def measure(spec: Path) -> dict:
    """One load in this process: seconds and peak resident bytes above the resident size before it."""
    import logging

    from symbolic.data import load

    logging.basicConfig(level=logging.WARNING)
    load(spec)  # a first load: the modules a load imports, imported before the measurement
    Path("/proc/self/clear_refs").write_text("5")
    before = status("VmRSS")
    start = time.perf_counter()
    loaded = load(spec)
    seconds = time.perf_counter() - start
    return {"seconds": seconds, "peak": status("VmHWM") - before, "held": status("VmRSS") - before,
            "samples": loaded.samples}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=300.0)
    parser.add_argument("--file", type=Path)
    parser.add_argument("--keep", action="store_true")
    parser.add_argument("--measure", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--out", type=Path, default=ROOT / "bench" / "results" / "bag_load.md")
    args = parser.parse_args()
    if args.measure:
        print(json.dumps(measure(args.measure)))
        return
    folder = Path(tempfile.mkdtemp()) if args.file is None else args.file.parent
    path = args.file or folder / "arm.mcap"
    if not path.is_file():
        started = time.perf_counter()
        counts = generate(path, args.seconds)
        print(f"wrote {path} ({counts[0]} + {counts[1]} messages) in {time.perf_counter() - started:.1f} s",
              file=sys.stderr)
    spec = experiment(path)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), *sys.path])}
    done = subprocess.run([sys.executable, __file__, "--measure", str(spec)], capture_output=True, text=True, env=env,
                          check=True)
    result = json.loads(done.stdout.strip().splitlines()[-1])
    size = path.stat().st_size
    messages = result["samples"] + (result["samples"] + 1) // 2
    kept = 8 * (result["samples"] * (1 + 14) + (result["samples"] + 1) // 2 * (1 + 7))  # the series read
    aligned = 8 * result["samples"] * (1 + 21)
    load_avg = os.getloadavg()[0]
    lines = [
        "# Loading a large MCAP bag: time and peak memory", "",
        f"`bench/bag_load.py`: an MCAP file of a 7-joint arm, {args.seconds:g} s of sensor_msgs/JointState at 1 kHz "
        f"(header stamps; 7 positions, velocities, efforts) and std_msgs/Float64MultiArray commands at 500 Hz, "
        f"{messages:,} messages, zstd chunks, {size / 2**20:.0f} MiB; `symbolic.data.load` of an experiment mapping 7 "
        f"positions, 7 efforts and 7 commands, in a fresh process on {platform.machine()}, Python "
        f"{platform.python_version()}, NumPy {np.__version__}; peak = the highest resident memory during the call "
        "minus the resident memory before it (after a first load of the same file, which imports what a load "
        "imports); held = what stays resident after it. A 2-core machine shared with "
        f"other work (load average {load_avg:.1f}).", "",
        "| messages | file (MiB) | seconds | messages/s | peak (MiB) | held (MiB) | numbers kept while reading (MiB) | "
        "aligned signals (MiB) |",
        "|---|---|---|---|---|---|---|---|",
        f"| {messages:,} | {size / 2**20:.0f} | {result['seconds']:.1f} | {messages / result['seconds']:,.0f} | "
        f"{result['peak'] / 2**20:.0f} | {result['held'] / 2**20:.0f} | {kept / 2**20:.0f} | {aligned / 2**20:.0f} |",
        "",
        "The reader holds one decompressed chunk of the file and, per topic, its times and the numbers referenced "
        "(arrays sized from the file's message counts), never the file: the peak is that, the aligned signals and "
        "the checks' copies.",
    ]
    args.out.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    if args.file is None and not args.keep:
        path.unlink()
        spec.unlink()


if __name__ == "__main__":
    main()

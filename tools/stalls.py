#!/usr/bin/env python3
"""Where a render's time waits, instruction by instruction: samples the program's clock with
`perf record -e cpu-clock` (a software event: it needs no hardware counters, which virtual
machines often lack), takes the instructions most samples land on in the hottest functions,
and prints the code just before each with its source lines. Where a load from the stack reads
bytes that earlier stores in the same stretch wrote only in part (a 16-byte load over a vector
stored as 8 bytes and 4, say), it says so: such a load cannot take its value from the store
buffer and waits until the stores reach the cache, a stall that instruction counts
(`tools/instructions_per_path.py`) never show. A sample lands on the instruction after the
one that waited, or a few after.

    python3 tools/stalls.py [SHOT] [--spp N] [--rift BINARY] [--functions N] [--top N]

The shot renders on one thread (the Cornell box at 32 spp unless told). Needs `perf`
(Debian: `apt-get install linux-perf`), `objdump` (binutils) and a release build with
debug lines (the release profile keeps them). Time follows the training profile: measure
the build that ships (`tools/pgo_profile.sh` after changing hot code).
"""
import argparse
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

BYTE_REGISTERS = ("al", "bl", "cl", "dl", "sil", "dil", "bpl", "spl")


def width(mnemonic, operands):
    """Bytes `mnemonic` moves to or from memory, or None if unknown: from the mnemonic for
    scalar moves and operations, else from the width of its register."""
    fixed = {"movb": 1, "movzbl": 1, "movsbl": 1, "movw": 2, "movzwl": 2, "movl": 4,
             "vinsertps": 4, "vmovd": 4, "vpinsrd": 4, "vpextrd": 4, "vpbroadcastd": 4,
             "vmovq": 8, "vpinsrq": 8, "vpextrq": 8, "vpbroadcastq": 8, "vmovlps": 8,
             "vmovhps": 8, "vmovddup": 8}
    if mnemonic in fixed:
        return fixed[mnemonic]
    # Scalar single and double operations: vmovss, vmulss, vbroadcastss, vaddsd, ...
    if mnemonic.startswith("v") and mnemonic.endswith("ss"):
        return 4
    if mnemonic.startswith("v") and mnemonic.endswith("sd"):
        return 8
    registers = [r for r in re.findall(r"%([a-z0-9]+)", operands) if r != "rsp"]
    for r in registers:
        if r.startswith("ymm"):
            return 32
        if r.startswith("xmm"):
            return 16
        if r in BYTE_REGISTERS or re.fullmatch(r"r\d+b", r):
            return 1
        if re.fullmatch(r"r\d+w|[abcd]x|[sd]i|bp", r):
            return 2
        if r.startswith("e") or re.fullmatch(r"r\d+d", r):
            return 4
        if r.startswith("r"):
            return 8
    return None


def stack_access(mnemonic, operands, frame):
    """('store' or 'load', offset, bytes) for an instruction that moves to or from the stack
    frame (through the stack pointer, or a register `frame` maps to an offset in it), else
    None."""
    m = re.search(r"(-?0x[0-9a-f]+)?\(%(\w+)\)", operands)
    if not m or mnemonic.startswith(("lea", "cmp", "push", "pop", "call", "prefetch")):
        return None
    base = 0 if m.group(2) == "rsp" else frame.get(m.group(2))
    size = width(mnemonic, operands)
    if base is None or size is None:
        return None
    kind = "store" if operands.rstrip().endswith(")") else "load"
    return kind, base + int(m.group(1) or "0", 16), size


def disassemble(binary, start, stop):
    """(address, mnemonic, operands, source) for the instructions in [start, stop)."""
    done = subprocess.run(["objdump", "-d", "-l", "--no-show-raw-insn",
                           f"--start-address={start:#x}", f"--stop-address={stop:#x}", binary],
                          check=True, capture_output=True, text=True)
    rows, source = [], ""
    for line in done.stdout.splitlines():
        m = re.match(r"\s+([0-9a-f]+):\s+(\S+)\s*(.*)", line)
        if m:
            rows.append((int(m.group(1), 16), m.group(2), m.group(3), source))
        elif re.match(r"^/.*:\d+", line):
            source = re.sub(r"^.*?/(render|fx|library|glam-[^/]+)/", r"\1/", line.split()[0])
    return rows


def straddling(rows):
    """Loads in the last instructions of `rows` that read stack bytes the earlier stores of
    `rows` wrote only in part, or from more than one store: (load row, the stores' rows)."""
    stores, found, frame = [], [], {}
    for i, (address, mnemonic, operands, source) in enumerate(rows):
        pointer = re.fullmatch(r"lea\s+(-?0x[0-9a-f]+)?\(%rsp\),%(\w+)", f"{mnemonic} {operands}")
        if pointer:
            frame[pointer.group(2)] = int(pointer.group(1) or "0", 16)
            continue
        access = stack_access(mnemonic, operands, frame)
        # A register written by anything else no longer points into the frame.
        target = re.search(r",%(\w+)$", operands)
        if target:
            frame.pop(target.group(1), None)
        if access is None:
            continue
        kind, offset, size = access
        if kind == "store":
            stores.append((offset, size, rows[i]))
            continue
        if i < len(rows) - 8:
            continue
        # Each byte comes from the latest store that wrote it (or from the cache); one store
        # holding the whole load forwards it, anything else waits.
        sources = [next((s for s in reversed(stores) if s[0] <= b < s[0] + s[1]), None)
                   for b in range(offset, offset + size)]
        written = [s for s in dict.fromkeys(sources) if s is not None]
        if written and (len(written) > 1 or None in sources):
            found.append((rows[i], [s[2] for s in written]))
    return found


def hottest_functions(data, count):
    done = subprocess.run(["perf", "report", "-i", data, "--no-children", "--sort", "symbol",
                           "--stdio"], check=True, capture_output=True, text=True)
    functions = []
    for line in done.stdout.splitlines():
        m = re.match(r"\s+([0-9.]+)%\s+\[\.\]\s+(.+?)\s*$", line)
        if m:
            # perf pads the name with columns of its own ("-  -").
            functions.append((float(m.group(1)), m.group(2).split("  ")[0]))
    return functions[:count]


def hottest_instructions(data, function, count):
    done = subprocess.run(["perf", "annotate", "-i", data, "--stdio", "-s", function],
                          check=True, capture_output=True, text=True)
    rows = []
    for line in done.stdout.splitlines():
        m = re.match(r"\s+([0-9.]+)\s+:\s+([0-9a-f]+):", line)
        if m:
            rows.append((float(m.group(1)), int(m.group(2), 16)))
    return sorted(rows, reverse=True)[:count]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("shot", nargs="?", default=str(ROOT / "examples/cornell.toml"))
    parser.add_argument("--spp", type=int, default=32)
    parser.add_argument("--rift", default=str(ROOT / "target/release/rift"))
    parser.add_argument("--functions", type=int, default=3)
    parser.add_argument("--top", type=int, default=12)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        data = f"{tmp}/perf.data"
        try:
            subprocess.run(["perf", "record", "-q", "-e", "cpu-clock", "-F", "5000", "-o", data,
                            args.rift, "render", args.shot, "-o", f"{tmp}/out.exr",
                            "--spp", str(args.spp), "--threads", "1"],
                           check=True, capture_output=True)
        except FileNotFoundError:
            sys.exit("tools/stalls.py: perf is not installed (Debian: apt-get install linux-perf)")
        except subprocess.CalledProcessError as e:
            sys.exit(f"tools/stalls.py: the render failed: {e.stderr.decode()[-400:]}")
        for share, function in hottest_functions(data, args.functions):
            print(f"\n{share:5.1f}% of the time in {function}")
            for part, address in hottest_instructions(data, function, args.top):
                rows = disassemble(args.rift, address - 160, address + 1)
                source = rows[-1][3] if rows else ""
                print(f"  {share * part / 100:5.2f}% at {address:#x} {source}")
                for (_, mnemonic, operands, src), stores in straddling(rows):
                    print(f"        waits on a load: {mnemonic} {operands}  ({src})")
                    for _, m, o, s in stores:
                        print(f"          over the store {m} {o}  ({s})")


if __name__ == "__main__":
    main()

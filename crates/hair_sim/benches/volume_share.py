#!/usr/bin/env python3
"""The share of a `perf record` profile spent in hair volume's code (`solver/volume`).

The feedback is inlined into the step's SIMD path, so a profile's symbols cannot tell it
apart from the step: each sampled address's chain of inlined functions is read from the
bench's line tables (`addr2line -i`), and a sample counts where any frame of the chain
lies in `solver/volume`. Build the bench with line tables, then profile one variant:

    CARGO_PROFILE_BENCH_DEBUG=line-tables-only cargo bench -p hair_sim --bench solver --no-run
    perf record -D 9000 -o volume.data BENCH --bench 'volume 2048x16/step on 1 threads, volume on$' --profile-time 20
    python3 crates/hair_sim/benches/volume_share.py volume.data BENCH

Prints the share, then the share of each outermost volume function (the splat's run,
`feed_back`, the cells' values, the pressure's sweeps, the step's take-back).
"""
import collections
import subprocess
import sys


def main(data: str, binary: str) -> None:
    samples = subprocess.run(
        ["perf", "script", "-i", data, "-F", "ip,sym,symoff,dso"], capture_output=True, text=True, check=True
    ).stdout
    # perf names a sample by its symbol and offset; the symbol's address comes from `nm`.
    demangled = subprocess.run(["nm", "-C", "--defined-only", binary], capture_output=True, text=True, check=True)
    start = {}
    for line in demangled.stdout.splitlines():
        parts = line.split(" ", 2)
        if len(parts) == 3:
            start.setdefault(parts[2], int(parts[0], 16))
    total, at = 0, collections.Counter()
    name = binary.rsplit("/", 1)[-1]
    for line in samples.splitlines():
        line = line.strip()
        if not line:
            continue
        total += 1
        if f"/{name})" not in line and f"({name})" not in line:
            continue
        symbol = line.rsplit(" (", 1)[0].split(" ", 1)[-1]
        if "+0x" in symbol:
            symbol, offset = symbol.rsplit("+0x", 1)
            if symbol in start:
                at[start[symbol] + int(offset, 16)] += 1
    chains = subprocess.run(
        ["addr2line", "-i", "-f", "-C", "-a", "-e", binary],
        input="\n".join(hex(a) for a in at),
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    # addr2line prints each address, then per inlined frame, innermost first: the
    # function, then the file and line it is at.
    volume, by_function = 0, collections.Counter()
    address, frames, function = None, [], None

    def count() -> None:
        nonlocal volume
        inside = [f for f, place in frames if "/solver/volume" in place]
        if address is not None and inside:
            volume += at[address]
            by_function[inside[-1].rsplit("::", 1)[-1]] += at[address]

    for line in chains.splitlines():
        if line.startswith("0x"):
            count()
            address, frames = int(line, 16), []
        elif function is None:
            function = line
        else:
            frames.append((function, line))
            function = None
    count()
    print(f"volume {100 * volume / max(total, 1):.1f} % of {total} samples")
    for function, samples in by_function.most_common():
        print(f"  {100 * samples / max(total, 1):.1f} % {function}")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])

"""What the comparison scripts say about the machine they ran on: comparisons against renderers
that compile for the processor they find (Mitsuba's LLVM kernels, Embree's ISA dispatch) follow
its vector width, so a figure is only comparable with one from the same kind of processor."""
import os
import platform


def describe():
    """'<processor model>, <n> threads, AVX-512: yes/no' (Linux's /proc/cpuinfo; elsewhere the
    platform's processor name)."""
    model, flags = platform.processor() or platform.machine(), set()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                key, _, value = line.partition(":")
                if key.strip() == "model name":
                    model = value.strip()
                elif key.strip() == "flags":
                    flags = set(value.split())
                    break
    except OSError:
        pass
    wide = "yes" if "avx512f" in flags else "no" if flags else "unknown"
    return f"{model}, {os.cpu_count()} threads, AVX-512: {wide}"

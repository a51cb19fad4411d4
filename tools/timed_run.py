"""Wall time and peak memory of one rift command, as GNU time measures them: shared by the
benchmark scripts that compare whole runs."""
import os
import re
import subprocess


def timed_run(rift, folder, shot):
    """Renders `shot` in `folder` with `rift` to o.exr: (wall seconds, peak RSS in MiB)."""
    out = subprocess.run(["/usr/bin/time", "-v", os.path.abspath(rift), "render", shot, "-o", "o.exr"],
                         cwd=folder, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (?:(\d+):)?(\d+):([\d.]+)", out.stderr)
    seconds = int(wall.group(1) or 0) * 3600 + int(wall.group(2)) * 60 + float(wall.group(3))
    rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", out.stderr).group(1)) / 1024
    return seconds, rss

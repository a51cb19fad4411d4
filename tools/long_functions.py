"""Lists the Rust functions longer than a limit (default 80 lines, from `fn` to its closing
brace), longest first, with their file and line, so long loaders can be found and split:

    python3 tools/long_functions.py [--limit 80] [--tests] [DIR...]   (default: render fx src)

Test modules (`#[cfg(test)]`) and `tests/` folders are left out unless --tests is given.
Braces in strings, characters and comments are skipped.
"""

from pathlib import Path
import argparse
import re

ROOT = Path(__file__).resolve().parent.parent
FN = re.compile(r"^\s*(?:pub(?:\([^)]*\))?\s+)?(?:const\s+)?(?:unsafe\s+)?(?:extern\s+\"C\"\s+)?fn\s+(\w+)")


def code_only(text):
    """`text` with comments, strings and character literals blanked, line breaks kept."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == "r" and re.match(r'r#*"', text[i:i + 8]) and not text[i - 1:i].isalnum():
            hashes = re.match(r'r(#*)"', text[i:]).group(1)
            end = text.find('"' + hashes, i + len(hashes) + 2)
            j = n if end < 0 else end + 1 + len(hashes)
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            out.append(re.sub(r"[^\n]", " ", text[i:j + 1]))
            i = j + 1
        elif c == "'" and re.match(r"'(\\.|[^\\'])'", text[i:i + 4]) or text.startswith("'\\u{", i):
            j = text.find("'", i + 1 + (text[i + 1] == "\\"))
            out.append(" " * (j + 1 - i))
            i = j + 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def functions(path, with_tests):
    """(lines, name, first line) of each function in `path`."""
    raw = path.read_text()
    lines, raw_lines = code_only(raw).split("\n"), raw.split("\n")
    found, depth, open_fns, test_depth = [], 0, [], None
    pending_test = False
    for number, line in enumerate(lines, 1):
        if "#[cfg(test)]" in raw_lines[number - 1]:
            pending_test = True
        m = FN.match(line)
        if m and (with_tests or test_depth is None):
            open_fns.append((m.group(1), number, depth))
        for c in line:
            if c == "{":
                if pending_test and test_depth is None:
                    test_depth = depth
                    pending_test = False
                depth += 1
            elif c == "}":
                depth -= 1
                if open_fns and open_fns[-1][2] == depth:
                    name, start, _ = open_fns.pop()
                    found.append((number - start + 1, name, start))
                if test_depth is not None and depth == test_depth:
                    test_depth = None
            elif c == ";" and open_fns and open_fns[-1][2] == depth:
                open_fns.pop()  # a declaration without a body (trait method)
    return found


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--limit", type=int, default=80)
    p.add_argument("--tests", action="store_true")
    p.add_argument("dirs", nargs="*", default=["render", "fx", "src"])
    a = p.parse_args()
    rows = []
    for d in a.dirs:
        for path in sorted((ROOT / d).rglob("*.rs")):
            rel = path.relative_to(ROOT)
            if "target" in rel.parts or (not a.tests and "tests" in rel.parts):
                continue
            rows += [(n, f"{rel}:{line}", name) for n, name, line in functions(path, a.tests)]
    long = sorted((r for r in rows if r[0] > a.limit), reverse=True)
    for n, where, name in long:
        print(f"{n:5}  {name}  {where}")
    print(f"{len(long)} of {len(rows)} functions over {a.limit} lines")


if __name__ == "__main__":
    main()

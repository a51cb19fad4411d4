"""Checks that every module the given Python scripts import comes from Python itself or from a
distribution that a line of the requirements file names (its environment marker holding here).

    requirements_check.py REQUIREMENTS SCRIPT...

A module that some other package happened to bring along (a dependency's dependency, or a
package installed by hand) does not count: only the requirements file's own lines do, so the
suite's environment can be made again from that file alone. Prints one line per script and
module; exits 1 naming each module that no line provides.
"""

import ast
import importlib.metadata
import inspect
import sys

from pip._vendor.packaging.requirements import Requirement
from pip._vendor.packaging.utils import canonicalize_name


def listed_distributions(path):
    """The canonical names of the distributions the requirements file's lines install here."""
    names = set()
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            text = line.split("#", 1)[0].strip()
            if not text:
                continue
            try:
                requirement = Requirement(text)
            except Exception as e:  # the vendored parser's own error type varies by pip version
                sys.exit(f"{path}:{number}: not a requirement line ({e})")
            if requirement.marker is None or requirement.marker.evaluate():
                names.add(canonicalize_name(requirement.name))
    return names


def module_owners():
    """Top-level module name -> canonical names of the installed distributions that hold it."""
    owners = {}
    for dist in importlib.metadata.distributions():
        name = canonicalize_name(dist.metadata["Name"])
        for file in dist.files or []:
            parts = file.parts
            if not parts or parts[0] in ("..", "__pycache__") or parts[0].endswith(
                (".dist-info", ".data", ".egg-info")
            ):
                continue
            top = parts[0] if len(parts) > 1 else inspect.getmodulename(parts[0])
            if top:
                owners.setdefault(top, set()).add(name)
    return owners


def imported_modules(script):
    """The top-level modules `script` imports (absolute imports only), in order."""
    with open(script, encoding="utf-8") as f:
        tree = ast.parse(f.read(), script)
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [alias.name.split(".")[0] for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.append(node.module.split(".")[0])
    return list(dict.fromkeys(found))


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    requirements, scripts = sys.argv[1], sys.argv[2:]
    listed = listed_distributions(requirements)
    owners = module_owners()
    missing = []
    for script in scripts:
        for module in imported_modules(script):
            if module in sys.stdlib_module_names:
                print(f"{script}: {module}: Python's own")
                continue
            providers = sorted(owners.get(module, set()) & listed)
            if providers:
                print(f"{script}: {module}: {', '.join(providers)}")
                continue
            installed = sorted(owners.get(module, set()))
            how = (
                f"installed by {', '.join(installed)}, which no line names"
                if installed
                else "not installed"
            )
            missing.append(f"{script}: module {module} is {how}; add its package to {requirements}")
    for line in missing:
        print(line, file=sys.stderr)
    sys.exit(1 if missing else 0)


if __name__ == "__main__":
    main()

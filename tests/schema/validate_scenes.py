#!/usr/bin/python3
"""The scene files' JSON Schema (data/schema/scene.schema.json) against the scenes and the loader.

Every shipped scene (data/scenes/*.yaml, examples) validates; every scene of the broken corpus
(tests/data/scenes/broken/*.yaml, first line `# key: PATH`) is refused by the schema and by the
loader (`palpate run`), each naming the same key. Run by ctest with Debian's python3 and its
python3-jsonschema and python3-yaml (scripts/install-deps); a missing module fails the test.
Usage: validate_scenes.py SCHEMA PALPATE_CLI SCENE_OR_DIR...  (the broken corpus: --broken DIR)
"""
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import jsonschema
import yaml


class Yaml12Loader(yaml.SafeLoader):
    """PyYAML reads YAML 1.1, where `1e-3` is a string; scenes are YAML 1.2 (yaml-cpp, editors),
    where it is a number. The 1.2 core schema's float pattern, added as an implicit resolver."""


Yaml12Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^(?:[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$"),
    list("-+0123456789."),
)


def load(path):
    with open(path, encoding="utf-8") as f:
        return yaml.load(f, Loader=Yaml12Loader)


def path_text(parts):
    """An error's path as the loader writes keys: tissues[0].material.poisson_ratio."""
    out = ""
    for p in parts:
        out += f"[{p}]" if isinstance(p, int) else (("." if out else "") + str(p))
    return out


def names_key(where, message, key):
    """Whether an error at `where` (a key path) with `message` names `key`: at the key itself, or
    at its parent with the key's last part quoted in the message (a missing or unexpected key)."""
    if where == key:
        return True
    parent, _, last = key.rpartition(".")
    return where == parent and f"'{last}'" in message


def loader_names_key(stderr, key):
    """The loader's messages read `FILE:LINE: KEY: what`; a missing or unexpected key is named
    under its parent (`device.waypoints[0]: missing required key 't'`)."""
    parent, _, last = key.rpartition(".")
    return f": {key}:" in stderr or (f": {parent}:" in stderr and f"'{last}'" in stderr)


def all_errors(errors):
    for e in errors:
        yield e
        yield from all_errors(e.context or [])


def main(argv):
    schema = json.loads(Path(argv[1]).read_text(encoding="utf-8"))
    jsonschema.Draft202012Validator.check_schema(schema)
    validator = jsonschema.Draft202012Validator(schema)
    cli = argv[2]
    good, broken, failures = [], [], []
    args = iter(argv[3:])
    for a in args:
        if a == "--broken":
            broken += sorted(Path(next(args)).glob("*.yaml"))
        else:
            p = Path(a)
            good += sorted(p.glob("*.yaml")) if p.is_dir() else [p]
    assert good and broken, "nothing to check"

    for scene in good:
        errs = sorted(validator.iter_errors(load(scene)), key=lambda e: list(e.absolute_path))
        for e in errs:
            failures.append(f"{scene}: {path_text(e.absolute_path) or '(top)'}: {e.message}")
    print(f"{len(good)} shipped scenes checked against the schema")

    with tempfile.TemporaryDirectory() as out:
        for scene in broken:
            first = scene.read_text(encoding="utf-8").splitlines()[0]
            assert first.startswith("# key: "), f"{scene}: first line must be '# key: PATH'"
            key = first[len("# key: "):].strip()
            errs = list(all_errors(validator.iter_errors(load(scene))))
            if not errs:
                failures.append(f"{scene}: the schema accepts it (expected an error naming {key})")
            elif not any(names_key(path_text(e.absolute_path), e.message, key) for e in errs):
                failures.append(f"{scene}: the schema's errors do not name {key}: "
                                + "; ".join(f"{path_text(e.absolute_path) or '(top)'}: {e.message}" for e in errs))
            run = subprocess.run([cli, "run", "-q", str(scene), "-o", out], capture_output=True, text=True,
                                 timeout=120)
            if run.returncode == 0:
                failures.append(f"{scene}: the loader accepts it (expected an error naming {key})")
            elif not loader_names_key(run.stderr, key):
                failures.append(f"{scene}: the loader's error does not name {key}: {run.stderr.strip()}")
            else:
                print(f"{scene.name}: both name {key}")
    print(f"{len(broken)} broken scenes checked against the schema and the loader")
    for f in failures:
        print("FAIL", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

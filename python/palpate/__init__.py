"""palpate — real-time soft tissue with force feedback, from Python (docs/python.md).

    import palpate
    sim = palpate.Simulation("data/scenes/default.yaml")     # the tool driven from Python
    f = sim.step([0, 0.001, 0])                               # one 1 ms tick: force on the device, N
    x, y, z = sim.tissue("skin").positions                    # read-only views of palpate's memory
    forces = sim.step_many(poses)                             # many ticks in C++, GIL released
    summary = palpate.run("data/scenes/cvc.yaml", out="out")  # `palpate run`, as a dict

Scenes come from a file, YAML text (parse_scene) or Python dicts (scene_from_dict): a dict is
written out as YAML and read by the same parser as a file, so its errors are the same, with the
line of the offending key in that text. Errors are palpate.Error with the command line's text.
"""
from ._palpate import (  # noqa: F401
    Error,
    Scene,
    Simulation,
    Tissue,
    __version__,
    info,
    load_scene,
    orientation_towards,
    parse_scene,
    precompute,
    run,
)

import json
import os

__all__ = [
    "Error", "Scene", "Simulation", "Tissue", "info", "load_scene", "orientation_towards",
    "parse_scene", "precompute", "run", "scene_from_dict", "scene_yaml",
]


def _scalar(value):
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(float(value)) if isinstance(value, float) else str(value)
    if isinstance(value, os.PathLike):
        value = os.fspath(value)
    if isinstance(value, str):
        return json.dumps(value)  # a JSON string is a YAML double-quoted scalar
    if hasattr(value, "tolist"):  # numpy scalars and arrays
        return _scalar(value.tolist()) if not isinstance(value.tolist(), list) else _flow(value.tolist())
    raise TypeError(f"scene_from_dict: cannot write {type(value).__name__} {value!r} into a scene")


def _flow(seq):
    return "[" + ", ".join(_scalar(v) for v in seq) + "]"


def _is_scalar_list(value):
    if hasattr(value, "tolist"):
        value = value.tolist()
    return isinstance(value, (list, tuple)) and all(not isinstance(v, (dict, list, tuple)) for v in value)


def _emit(value, indent, lines):
    pad = " " * indent
    if isinstance(value, dict):
        for key, v in value.items():
            if isinstance(v, dict):
                lines.append(f"{pad}{key}:")
                _emit(v, indent + 2, lines)
            elif _is_scalar_list(v):
                lines.append(f"{pad}{key}: {_flow(v.tolist() if hasattr(v, 'tolist') else v)}")
            elif isinstance(v, (list, tuple)):
                lines.append(f"{pad}{key}:")
                _emit(v, indent + 2, lines)
            else:
                lines.append(f"{pad}{key}: {_scalar(v)}")
    elif isinstance(value, (list, tuple)):
        for item in value:
            if isinstance(item, dict):
                sub = []
                _emit(item, indent + 2, sub)
                if sub:
                    sub[0] = pad + "- " + sub[0][indent + 2:]
                else:
                    sub = [pad + "- {}"]
                lines.extend(sub)
            elif _is_scalar_list(item):
                lines.append(f"{pad}- {_flow(item)}")
            else:
                lines.append(f"{pad}- {_scalar(item)}")
    else:
        raise TypeError("scene_from_dict: a scene is a dict")


def scene_yaml(scene: dict) -> str:
    """The YAML text scene_from_dict parses: one key a line, so an error's line number finds it."""
    if not isinstance(scene, dict):
        raise TypeError("scene_yaml: a scene is a dict")
    lines = []
    _emit(scene, 0, lines)
    return "\n".join(lines) + "\n"


def scene_from_dict(scene: dict, name: str = "<dict>", base_dir=".") -> Scene:
    """A Scene from nested dicts and lists with the keys of a scene file (docs/scene-format.md).

    Relative paths (meshes, predictors, output) resolve against `base_dir`. Errors are
    palpate.Error naming `name`, the line in scene_yaml(scene) and the key, as for a file.
    """
    return parse_scene(scene_yaml(scene), name, os.fspath(base_dir))

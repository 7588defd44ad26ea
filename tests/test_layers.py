"""The packages' layers: physics knows nothing of Gymnasium, the env nothing of RL libraries or of the
agents package, and within the agents package nothing imports upwards or in a circle."""

import ast
from pathlib import Path

import pytest

from tests import ROOT

#: Layers from the bottom: a module may import its own layer and the layers below it.
AGENT_LAYERS = (
    {"blas", "cycles", "yaml_config", "run_record", "sb3_files", "drive"},
    {"protocol"},
    {"policy", "search", "vec_env", "sensor_episodes"},
    {"teacher"},
    {"student"},
    {"train", "benchmarks"},
    {"rl_baselines"},
    {"commands"},
)


def imports(path: Path, package: str) -> set[str]:
    """The absolute names a module imports (relative imports resolved against ``package``)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - node.level + 1]
                names.add(".".join(base + ([node.module] if node.module else [])))
                if not node.module:
                    names |= {".".join(base + [a.name]) for a in node.names}
            else:
                names.add(node.module)
    return names


def modules(folder: Path, package: str):
    """(path, the package its relative imports resolve against) of every module under ``folder``."""
    for path in sorted(folder.rglob("*.py")):
        yield path, ".".join([package, *path.relative_to(folder).parts[:-1]])


def test_the_physics_package_never_imports_the_agents_package_or_rl_libraries():
    for path, package in modules(ROOT / "mdr_drive_env", "mdr_drive_env"):
        found = {n for n in imports(path, package) if n.split(".")[0] in ("mdr_drive_agents", "stable_baselines3",
                                                                            "torch", "sb3_contrib")}
        assert not found, (path, found)


def test_the_core_knows_nothing_of_gymnasium():
    for path, package in modules(ROOT / "mdr_drive_env" / "core", "mdr_drive_env.core"):
        assert not {n for n in imports(path, package) if n.split(".")[0] == "gymnasium"}, path


@pytest.mark.parametrize("path", sorted((ROOT / "agents").rglob("*.py")), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_agents_module_imports_a_layer_above_its_own(path):
    parts = path.relative_to(ROOT / "agents").with_suffix("").parts
    if parts == ("__init__",):
        return
    own = next(i for i, layer in enumerate(AGENT_LAYERS) if parts[0] in layer)
    package = ".".join(["mdr_drive_agents", *parts[:-1]])
    for name in imports(path, package):
        if name.startswith("mdr_drive_agents."):
            top = name.split(".")[1]
            target = next(i for i, layer in enumerate(AGENT_LAYERS) if top in layer)
            assert target <= own, f"{path.relative_to(ROOT)} imports {name} (layer {target} above {own})"


def test_teacher_and_student_do_not_import_each_other_in_a_circle():
    for path, package in modules(ROOT / "agents" / "teacher", "mdr_drive_agents.teacher"):
        assert not {n for n in imports(path, package) if n.startswith("mdr_drive_agents.student")}, path


def test_the_benchmarks_never_import_the_training_programs():
    """A result judges a policy without the code that built it: benchmarks/ and train/ share only what
    lies below both."""
    for path, package in modules(ROOT / "agents" / "benchmarks", "mdr_drive_agents.benchmarks"):
        assert not {n for n in imports(path, package) if n.startswith("mdr_drive_agents.train")}, path

"""The layers of docs/ARCHITECTURE.md against the code: every `legplan.X` import of every module (top
level and inside functions) goes to a lower layer, or within its layer only where the table allows."""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LAYERS = {
    "errors": 0, "interrupts": 0, "native_stderr": 0, "parameters": 0, "specio": 0, "geometry": 0,
    "budget": 0, "outputs_apart": 0, "shipped": 0, "_lazy_numpy_clone": 0, "cache": 0, "lazy_exports": 0,
    "solve": 1, "artefacts": 1,
    "terrain": 2, "robots": 2, "contact": 2, "batch": 2, "pipeline": 2,
    "validate": 3,
    "dyn": 4, "nav": 4, "stepplan": 4, "stepseq": 4,
    "learn": 5, "sim": 5, "baselines": 5,
    "export": 5,
    "report": 6,
    "cli": 7, "__main__": 7,
}
SAME_LAYER = {("parameters", "errors"), ("specio", "errors"), ("budget", "errors"), ("outputs_apart", "errors"),
              ("shipped", "errors"), ("specio", "parameters"), ("__main__", "cli")}


def _imports(path: Path):
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module]
        elif isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        else:
            continue
        for name in names:
            parts = name.split(".")
            if parts[0] == "legplan" and len(parts) > 1:
                yield node.lineno, parts[1]


def test_every_package_has_a_layer():
    packages = {p.stem if p.is_file() else p.name for p in (ROOT / "legplan").iterdir()
                if (p.suffix == ".py" and p.stem != "__init__") or (p / "__init__.py").is_file()}
    assert packages == set(LAYERS)


def test_no_import_runs_up_or_sideways():
    wrong = []
    for path in sorted((ROOT / "legplan").rglob("*.py")):
        parts = path.relative_to(ROOT / "legplan").parts
        source = parts[0] if len(parts) > 1 else path.stem
        if source == "__init__":
            continue
        for line, target in _imports(path):
            if target == source or target not in LAYERS:
                continue
            up = LAYERS[target] > LAYERS[source]
            sideways = LAYERS[target] == LAYERS[source] and (source, target) not in SAME_LAYER
            if up or sideways:
                wrong.append(f"{path.relative_to(ROOT)}:{line} {source} (layer {LAYERS[source]}) imports "
                             f"{target} (layer {LAYERS[target]})")
    assert not wrong, "\n".join(wrong)

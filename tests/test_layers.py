"""The layering of widesky (docs ARCHITECTURE, section 2) as a checked contract.

``pyproject.toml`` ``[tool.importlinter]`` holds three import-linter contracts: the layers (core < skymodel <
irradiance < pvsim | thermal < app), no runtime module importing the dataset generator, and no import cycles between
the modules of a package. :func:`test_contracts_hold` runs ``lint-imports`` on them and fails with its report; the
other tests check that the contracts are not vacuous (an added forbidden import, layer violation or cycle breaks
them) and that the generator contract names every runtime module of skymodel.
"""

from __future__ import annotations

import copy
import subprocess
import sys
from pathlib import Path

import grimp
import pytest
from importlinter.api import read_configuration
from importlinter.contracts.acyclic_siblings import AcyclicSiblingsContract
from importlinter.contracts.forbidden import ForbiddenContract
from importlinter.contracts.layers import LayersContract

import widesky.skymodel

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = ROOT / "pyproject.toml"
CONTRACT_TYPES = {"layers": LayersContract, "forbidden": ForbiddenContract, "acyclic_siblings": AcyclicSiblingsContract}


def _config():
    return read_configuration(str(PYPROJECT))


def _contracts():
    """{contract id: contract object} of pyproject.toml."""
    cfg = _config()
    out = {}
    for opts in cfg["contracts_options"]:
        options = {k: v for k, v in opts.items() if k not in ("name", "type")}
        out[opts["id"]] = CONTRACT_TYPES[opts["type"]](opts["name"], cfg["session_options"], options)
    return out


@pytest.fixture(scope="module")
def graph():
    return grimp.build_graph("widesky", cache_dir=None)


def test_contracts_hold(tmp_path):
    """``lint-imports`` passes; on failure the message is its report (which contract, which import chain)."""
    # run outside the checkout: lint-imports puts its working directory first on sys.path, where the checkout's
    # widesky/ folder (the namespace root alone) would hide the installed package's subpackages
    run = subprocess.run([sys.executable, "-c", "from importlinter.cli import lint_imports_command as c; c()",
                          str(PYPROJECT), "--no-cache", "--no-logo"],
                         cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, f"import contracts broken (lint-imports):\n{run.stdout}\n{run.stderr}"


@pytest.mark.parametrize("contract_id, importer, imported", [
    # a runtime module importing the generator, directly
    ("no-generator-at-runtime", "widesky.irradiance.skies", "widesky.skymodel.generator.solver"),
    # ... or from skymodel's own runtime modules and package
    ("no-generator-at-runtime", "widesky.skymodel", "widesky.skymodel.generator"),
    ("no-generator-at-runtime", "widesky.skymodel.evaluate", "widesky.skymodel.generator.fit"),
    ("no-generator-at-runtime", "widesky.core.spectral", "widesky.skymodel.generator.channels_of_a_new_module"),
    # a lower layer importing a higher one, and two independent siblings importing each other
    ("layers", "widesky.skymodel.dataset", "widesky.irradiance.skies"),
    ("layers", "widesky.core.atomic", "widesky.skymodel.dataset"),
    ("layers", "widesky.irradiance.poa", "widesky.pvsim.system"),
    ("layers", "widesky.thermal.gains", "widesky.pvsim.module"),
    ("layers", "widesky.pvsim.system", "widesky.cases.report"),
    # a cycle between two modules of a package
    ("acyclic", "widesky.pvsim.spectra", "widesky.pvsim.system"),
    ("acyclic", "widesky.irradiance.patches", "widesky.irradiance.raycast"),
])
def test_contracts_catch_a_violation(graph, contract_id, importer, imported):
    """Each contract holds on the code as it is and breaks when one offending import is added to the graph."""
    contract = _contracts()[contract_id]
    assert contract.check(copy.deepcopy(graph), verbose=False).kept   # (a check removes the imports it ignores)
    g = copy.deepcopy(graph)
    for m in (importer, imported):
        if m not in g.modules:
            g.add_module(m)
    g.add_import(importer=importer, imported=imported, line_number=1, line_contents=f"import {imported}")
    assert not contract.check(g, verbose=False).kept, f"{contract_id} kept with {importer} -> {imported}"


def test_generator_contract_names_every_runtime_skymodel_module():
    """import-linter cannot say "skymodel except its generator", so the contract lists skymodel's runtime modules;
    this keeps the list complete (a new skymodel module must be added there)."""
    opts = next(o for o in _config()["contracts_options"] if o["id"] == "no-generator-at-runtime")
    listed = {m for m in opts["source_modules"] if m.startswith("widesky.skymodel")}
    folder = Path(widesky.skymodel.__file__).parent
    modules = {"widesky.skymodel"} | {f"widesky.skymodel.{p.stem}" for p in folder.glob("*.py") if p.stem != "__init__"}
    packages = {f"widesky.skymodel.{p.parent.name}" for p in folder.glob("*/__init__.py")}
    assert packages >= {"widesky.skymodel.generator"}
    expected = modules | {f"{p}.**" for p in packages - {"widesky.skymodel.generator"}} \
        | (packages - {"widesky.skymodel.generator"})
    assert listed == expected, (f"missing from the contract: {sorted(expected - listed)}; "
                                f"not skymodel runtime modules: {sorted(listed - expected)}")
    assert set(opts["forbidden_modules"]) == {"widesky.skymodel.generator", "widesky.skymodel.generator.**"}

"""Start-up stays cheap (issue 15 item 2): what ``import replication`` and ``--help`` load.

Each check runs in a fresh interpreter and reads ``sys.modules``: a heavy library imported at
start-up fails the test whatever the machine's speed (the times themselves are asv's
``timeraw_`` benchmarks in benchmarks/benchmark_startup.py).
"""

import json
import pickle
import subprocess
import sys

import pytest

import replication

#: Libraries that cost tens to hundreds of milliseconds to import, none needed to start.
HEAVY = ("numba", "llvmlite", "scipy", "pyvista", "vtk", "vtkmodules", "matplotlib", "pandas", "dask",
         "distributed", "geomdl", "tqdm")  # fmt: skip

#: Command modules: each is imported only when its command runs.
COMMAND_MODULES = ("surfaces", "force", "casestudy", "reports", "sph", "common", "compare", "files")


def _loaded_after(code: str) -> set[str]:
    """Top-level names of the modules a fresh interpreter has loaded after running ``code``."""
    probe = f"{code}\nimport json, sys\nprint(json.dumps(sorted(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True).stdout
    return set(json.loads(out.splitlines()[-1]))


def _heavy(modules: set[str]) -> list[str]:
    return sorted({m.split(".")[0] for m in modules} & set(HEAVY))


def test_import_replication_loads_nothing_heavy():
    modules = _loaded_after("import replication")
    assert _heavy(modules) == []
    assert "numpy" not in modules
    assert not any(m.startswith("replication.") and m != "replication._lazy" for m in modules)


@pytest.mark.parametrize("argv", [["--help"], ["--version"], ["bogus"], []])
def test_help_version_and_usage_errors_load_nothing_heavy(argv):
    code = f"from replication.cli import main\ntry:\n    main({argv!r})\nexcept SystemExit:\n    pass"
    modules = _loaded_after(code)
    assert _heavy(modules) == []
    assert "numpy" not in modules
    assert not [m for m in modules if m.removeprefix("replication.cli.") in COMMAND_MODULES]


def test_a_command_loads_only_its_own_module():
    code = (
        "from replication.cli import main\ntry:\n    main(['force', '--help'])\nexcept SystemExit:\n    pass"
    )
    modules = _loaded_after(code)
    assert "replication.cli.force" in modules
    assert not {"replication.cli.surfaces", "replication.cli.casestudy", "replication.cli.reports"} & modules
    assert not {"pandas", "matplotlib", "pyvista", "dask", "geomdl"} & {m.split(".")[0] for m in modules}


def test_adt_command_loads_no_plotting_tables_or_nurbs_library(tmp_path):
    out = tmp_path / "x.vtk"
    argv = ["adt", "--random", "30", "--seed", "1", "-o", str(out)]
    code = f"from replication.cli import main\nassert main({argv!r}) == 0"
    modules = _loaded_after(code)
    assert out.stat().st_size > 0
    assert not {"pandas", "matplotlib", "pyvista", "vtk", "vtkmodules", "dask", "geomdl"} & {
        m.split(".")[0] for m in modules
    }
    assert "scipy.stats" not in modules and "scipy.spatial" not in modules


def test_the_casestudy_command_starts_its_ga_before_loading_plotting_libraries(tmp_path):
    """The report's plotting (matplotlib, then pyvista) is loaded once the GA is done: the GA
    starts sooner, and a run stopped by Ctrl-C never loads it."""
    argv = ["casestudy", "--runs", "1", "--generations", "1", "--population", "6", "--executor", "serial",
            "--run-dir", str(tmp_path / "run"), "--output-dir", str(tmp_path / "out")]  # fmt: skip
    code = (
        "import json, sys\nimport replication.experiments.casestudy as E\nrun = E.run_casestudy\n"
        "def spy(*a, **k):\n    print(json.dumps(sorted(sys.modules)), file=sys.stderr)\n"
        "    return run(*a, **k)\nE.run_casestudy = spy\nfrom replication.cli import main\n"
        f"assert main({argv!r}) == 0"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    at_start = next(line for line in result.stderr.splitlines() if line.startswith("["))
    loaded = {m.split(".")[0] for m in json.loads(at_start)}
    assert not {"matplotlib", "pyvista", "vtk", "vtkmodules"} & loaded
    assert (tmp_path / "out" / "casestudy.md").is_file()  # and the report was drawn after all


def test_stats_loads_scipy_stats_on_first_use():
    modules = _loaded_after("import replication.stats")
    assert "scipy" not in {m.split(".")[0] for m in modules}


def test_top_level_help_lists_what_each_command_module_registers():
    import argparse

    from replication.cli import COMMANDS, build_parser

    full = build_parser()  # every command module registered
    sub = next(a for a in full._actions if isinstance(a, argparse._SubParsersAction))
    registered = {action.dest: action.help for action in sub._choices_actions}
    assert registered == {name: helptext for name, (_, helptext) in COMMANDS.items()}
    lazy = build_parser([])
    assert lazy.format_help() == full.format_help()


@pytest.mark.parametrize("name", ["adt", "compare", "force", "casestudy", "reproduce", "report", "sph"])
def test_each_command_parses_with_only_its_module_registered(name, capsys):
    from replication.cli import COMMANDS, build_parser

    parser = build_parser([name])
    with pytest.raises(SystemExit) as exit_:
        parser.parse_args([name, "--help"])
    assert exit_.value.code == 0
    usage = " ".join(capsys.readouterr().out.split())  # argparse wraps at the terminal's width (COLUMNS)
    assert usage.startswith(f"usage: replication {name} [-h]")  # the full parser
    assert name in COMMANDS


def test_the_command_is_found_after_top_level_options(capsys):
    from replication.cli import _command

    assert _command(["--debug", "adt", "-o", "x.vtk"]) == "adt"
    assert _command(["--", "force"]) == "force"
    assert _command(["--help"]) is None


# lazy package attributes (replication._lazy) behave like the eager imports they replace


def test_lazy_names_resolve_to_their_definitions():
    from replication import adt as from_import
    from replication.surfaces.adt import adt

    assert from_import is adt and replication.adt is adt
    assert replication.surfaces.adt is adt  # the function, as before, not the submodule
    surface = replication.adt(replication.random_cloud(20, rng=0))
    assert isinstance(surface, replication.Surface)


def test_every_exported_name_resolves_and_dir_lists_it():
    for package in (replication, replication.surfaces, replication.io, replication.casestudy):
        assert set(package.__all__) - {"__version__"} == set(package._EXPORTS)
        for name in package.__all__:
            assert getattr(package, name) is not None, (package.__name__, name)
        assert set(package.__all__) <= set(dir(package))
    assert isinstance(replication.__version__, str)


def test_unknown_names_raise_attribute_error_naming_them():
    with pytest.raises(AttributeError, match="no attribute 'nonexistent'"):
        replication.nonexistent  # noqa: B018
    assert not hasattr(replication.surfaces, "nonexistent")


def test_function_sharing_a_submodule_name_survives_importing_the_submodule():
    code = (
        "import replication, importlib\n"
        "importlib.import_module('replication.compare')\n"
        "import replication.compare as m\n"
        "assert callable(replication.compare) and replication.compare.__name__ == 'compare'\n"
        "assert importlib.import_module('replication.compare').__name__ == 'replication.compare'\n"
        "print('ok')"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "ok"


def test_functions_and_dataclasses_pickle_for_process_pools():
    config = replication.casestudy.JetConfig()
    for obj in (replication.adt, replication.compare, replication.casestudy.surface_force, config):
        assert pickle.loads(pickle.dumps(obj)) == obj
    surface = replication.adt(replication.random_cloud(12, rng=1))
    again = pickle.loads(pickle.dumps(surface))
    assert (again.triangles == surface.triangles).all()


def test_a_fresh_process_unpickles_lazily_exported_objects():
    payload = pickle.dumps((replication.adt, replication.casestudy.JetConfig(diameter=0.02)))
    code = (
        "import pickle, sys\n"
        "f, c = pickle.loads(sys.stdin.buffer.read())\n"
        "import replication\n"
        "assert f is replication.adt and c.diameter == 0.02\n"
        "print('ok')"
    )
    out = subprocess.run([sys.executable, "-c", code], input=payload, capture_output=True, check=True).stdout
    assert out.strip() == b"ok"

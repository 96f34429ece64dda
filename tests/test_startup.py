"""The fixed costs of every ``bootnav`` command (issue 25, item 5): what the start imports and how the program ends.

Each check runs a fresh interpreter, so what an earlier test imported does not hide an import.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from bootnav.cli import SUBCOMMANDS

REPO = Path(__file__).resolve().parents[1]


def _fresh(code: str) -> list[str]:
    """stdout words of ``code`` run by a fresh interpreter."""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120)
    return out.stdout.split()


def test_the_parser_of_one_command_imports_only_that_commands_module_and_no_numpy():
    names = [m for m, _ in SUBCOMMANDS.values()]
    words = _fresh("import sys\nimport bootnav.cli as c\np = c.build_parser(['-q', 'info', 'x.h5'])\n"
                   f"print(*[m in sys.modules for m in {names!r}])\nprint('numpy' in sys.modules)\n"
                   "print(p.parse_args(['info', 'x.h5']).file)")
    imported = dict(zip(names, words[:len(names)]))
    assert imported.pop("bootnav.logger.cli_info") == "True"
    assert set(imported.values()) == {"False"}, imported
    assert words[len(names):] == ["False", "x.h5"]


def test_the_whole_parser_imports_no_numpy():
    # `bootnav --help`: every subcommand's module, none of the numerics (the PDR package names its pipeline lazily)
    assert _fresh("import sys\nimport bootnav.cli as c\nc.build_parser()\nprint('numpy' in sys.modules)") == ["False"]


def test_the_recording_unit_check_does_not_load_the_importers_readers():
    words = _fresh("import sys\nfrom bootnav.logger.importers import checks\n"
                   "print('bootnav.logger.importers.core' in sys.modules, 'bootnav.logger.importers.stream' in sys.modules)")
    assert words == ["False", "False"]


def test_every_public_name_of_the_lazy_packages_resolves():
    words = _fresh("import bootnav.logger.importers as i, bootnav.postproc.pdr as p\n"
                   "print(all(callable(getattr(i, n)) for n in i.__all__), all(callable(getattr(p, n)) for n in p.__all__))\n"
                   "print(i.core.__name__, i.read_any.__module__, p.run_pdr.__module__)\n"
                   "try:\n    i.no_such_name\nexcept AttributeError:\n    print('AttributeError')")
    assert words == ["True", "True", "bootnav.logger.importers.core", "bootnav.logger.importers.core",
                     "bootnav.postproc.pdr.pipeline", "AttributeError"]


def test_only_the_programs_own_exit_freezes_the_garbage_collector():
    # main() run as the program (argv None) freezes the objects left, so the interpreter's teardown does not walk
    # them (0.3-0.8 s after `bootnav process` of 1 h); main() called from Python leaves the collector alone
    rec = str(REPO / "recordings" / "sim_paper-straight.h5")
    out = subprocess.run([sys.executable, "-c", "import gc, sys\nfrom bootnav.cli import main\n"
                          f"print('RESULT', main(['-q', 'info', {rec!r}]), gc.get_freeze_count() > 0)\n"
                          f"sys.argv = ['bootnav', '-q', 'info', {rec!r}]\n"
                          "print('RESULT', main(), gc.get_freeze_count() > 0)"],
                         capture_output=True, text=True, check=True, timeout=120).stdout
    assert [line for line in out.splitlines() if line.startswith("RESULT")] == ["RESULT 0 False", "RESULT 0 True"]


def test_process_freezes_the_import_objects_only_while_it_runs(tmp_path):
    # the objects the numerics' imports made are frozen during the run (no collection walks them), and the
    # collector is as before after it: enabled, nothing left frozen when main() is called from Python
    rec = str(REPO / "recordings" / "sim_paper-straight.h5")
    out = subprocess.run([sys.executable, "-c",
                          "import gc\nimport bootnav.postproc.pipeline as p\nfrom bootnav.cli import main\nseen = []\n"
                          "real = p.process_to\n"
                          "def spy(*a, **k):\n    seen.append((gc.get_freeze_count() > 10000, gc.isenabled()))\n"
                          "    return real(*a, **k)\n"
                          "p.process_to = spy\n"
                          f"code = main(['-q', 'process', {rec!r}, '--out', {str(tmp_path / 'o')!r}, '--no-plots'])\n"
                          "print('RESULT', code, seen, gc.get_freeze_count(), gc.isenabled())"],
                         capture_output=True, text=True, check=True, timeout=300).stdout
    assert [line for line in out.splitlines() if line.startswith("RESULT")] == ["RESULT 0 [(True, True)] 0 True"]

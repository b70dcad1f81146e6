"""scripts/check_sizes.py, the tree's size rules, finds what breaks them (and only that)."""
import os
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(os.environ.get("KINOLAB_SOURCE_DIR", Path(__file__).parents[2])) / "scripts" / \
    "check_sizes.py"


def run(root):
    return subprocess.run([sys.executable, str(SCRIPT), "--root", str(root)],
                          capture_output=True, text=True, check=False)


def cpp_function(name, lines):
    body = "".join(f"  x += {i};  // a string with a brace {{ and a // comment\n"
                   for i in range(lines - 2))
    return f"int {name}(int x) {{\n{body}}}\n"


def test_a_long_function_and_a_long_file_are_named(tmp_path):
    source = tmp_path / "framework" / "src"
    source.mkdir(parents=True)
    (source / "fine.cpp").write_text(cpp_function("short_one", 80) + "struct S {\n  int f() {\n"
                                     "    return 1;\n  }\n};\n")
    (tmp_path / "plugins").mkdir()
    (tmp_path / "plugins" / "long.cpp").write_text(
        "namespace n {\n" + cpp_function("too_long", 81) + "}  // namespace n\n")
    (tmp_path / "analysis").mkdir()
    (tmp_path / "analysis" / "big.py").write_text(
        "def small():\n    return 1\n" + "x = 1\n" * 600)
    result = run(tmp_path)
    assert result.returncode == 1
    assert "plugins/long.cpp:2: too_long is 81 lines" in result.stdout
    assert "analysis/big.py: 602 lines" in result.stdout
    assert "short_one" not in result.stdout and "fine.cpp" not in result.stdout


def test_a_tree_within_the_rules_passes(tmp_path):
    (tmp_path / "python").mkdir()
    (tmp_path / "python" / "ok.py").write_text("def f():\n" + "    pass\n" * 79)
    result = run(tmp_path)
    assert result.returncode == 0, result.stdout

#!/usr/bin/env python3
"""Holds the source tree to its size rules: no function over 80 lines and no source file
over 600 in framework/, plugins/, python/ and analysis/ (DESIGN.md, "Sizes").

A C++ function is a brace block whose opening follows a parameter list (a lambda inside a
function counts as part of it); a Python function is a `def` and the lines indented below it.
Lines are counted from the signature's first line to the closing brace (or the last body
line). Exits 1 and lists every breach.

    scripts/check_sizes.py [--root DIR] [--max-function N] [--max-file N]
"""
import argparse
import pathlib
import re
import sys

FOLDERS = ("framework", "plugins", "python", "analysis")
CPP = {".cpp", ".hpp", ".h", ".cc", ".in"}
CONTROL = re.compile(r"\b(if|for|while|switch|catch|do|else|try|return)\b\s*(\(|$|\{)")


def strip_cpp(text):
    """The text with comments, string and character literals blanked (newlines kept)."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append("".join(ch if ch == "\n" else " " for ch in text[i:j]))
            i = j
        elif text.startswith('R"', i):
            m = re.match(r'R"([^(]*)\(', text[i:])
            if m:
                end = text.find(")" + m.group(1) + '"', i)
                j = n if end < 0 else end + len(m.group(1)) + 2
                out.append("".join(ch if ch == "\n" else " " for ch in text[i:j]))
                i = j
            else:
                out.append(c)
                i += 1
        elif c in "\"'":
            j = i + 1
            while j < n and text[j] != c:
                j += 2 if text[j] == "\\" else 1
            out.append(" " * (min(j + 1, n) - i))
            i = j + 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def cpp_functions(text):
    """(name, first line, line count) of each outermost function body in C++ `text`."""
    code = strip_cpp(text)
    found = []
    stack = []  # per open brace: (is_function, start_line, name)
    inside = 0  # open function bodies
    for pos, ch in enumerate(code):
        if ch == "{":
            is_function = False
            name = ""
            if inside == 0:
                head = code[max(0, pos - 400):pos]
                stmt = re.split(r"[;{}]", head)[-1]
                flat = " ".join(stmt.split())
                m = re.search(r"([~\w:<>]+)\s*\([^()]*(\([^()]*\)[^()]*)*\)"
                              r"(\s*(const|override|final|noexcept|mutable|->\s*[\w:<>&*, ]+))*"
                              r"(\s*:\s*.*)?\s*$", flat)
                if m and not CONTROL.search(flat) and "=" not in flat.split("(")[0]:
                    is_function = True
                    name = m.group(1)
            start = code.count("\n", 0, pos - len(re.split(r"[;{}]", code[max(0, pos - 400):pos])[-1].lstrip())) + 1
            stack.append((is_function, start, name))
            if is_function:
                inside += 1
        elif ch == "}" and stack:
            is_function, start, name = stack.pop()
            if is_function:
                inside -= 1
                end = code.count("\n", 0, pos) + 1
                found.append((name, start, end - start + 1))
    return found


def python_functions(text):
    lines = text.split("\n")
    found = []
    for i, line in enumerate(lines):
        m = re.match(r"(\s*)(async\s+)?def\s+(\w+)", line)
        if not m:
            continue
        indent = len(m.group(1))
        last = i
        for j in range(i + 1, len(lines)):
            body = lines[j]
            if not body.strip():
                continue
            if len(body) - len(body.lstrip()) <= indent:
                break
            last = j
        found.append((m.group(3), i + 1, last - i + 1))
    return found


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--root", default=pathlib.Path(__file__).resolve().parent.parent,
                        type=pathlib.Path, help="the source tree (default: this checkout)")
    parser.add_argument("--max-function", type=int, default=80, help="lines per function")
    parser.add_argument("--max-file", type=int, default=600, help="lines per source file")
    args = parser.parse_args()
    breaches = []
    for folder in FOLDERS:
        for path in sorted((args.root / folder).rglob("*")):
            if not path.is_file() or path.suffix not in CPP | {".py"}:
                continue
            text = path.read_text(encoding="utf-8", errors="replace")
            rel = path.relative_to(args.root)
            count = text.count("\n")
            if count > args.max_file:
                breaches.append(f"{rel}: {count} lines (at most {args.max_file})")
            functions = python_functions(text) if path.suffix == ".py" else cpp_functions(text)
            for name, line, length in functions:
                if length > args.max_function:
                    breaches.append(f"{rel}:{line}: {name} is {length} lines "
                                    f"(at most {args.max_function})")
    for breach in breaches:
        print(breach)
    if breaches:
        print(f"{len(breaches)} size rule(s) broken", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""A markdown table of every parameter in a commented YAML file of config/ (name, default, what
it means, from the comment beside it), so the README's reference is generated, not retyped.

  scripts/lib/param_table.py config/ros.yaml            prints the table
  scripts/lib/param_table.py --check README.md config/ros.yaml
      exits 1 unless README.md holds exactly that table between the lines
      <!-- generated: scripts/lib/param_table.py config/ros.yaml --> and <!-- end generated -->
"""
import re
import sys

LINE = re.compile(r"^(?P<indent> *)(?P<key>[A-Za-z_][A-Za-z_0-9]*):(?P<value>[^#]*)(#\s?(?P<comment>.*))?$")


def rows(path):
    """(section/name, default, comment) of every leaf, in file order."""
    stack = []  # (indent, key)
    out = []
    for raw in open(path, encoding="utf-8"):
        line = raw.rstrip("\n")
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        m = LINE.match(line)
        if not m:
            continue
        indent = len(m.group("indent"))
        while stack and stack[-1][0] >= indent:
            stack.pop()
        value = m.group("value").strip()
        if value == "":
            stack.append((indent, m.group("key")))
            continue
        name = "/".join([k for _, k in stack] + [m.group("key")])
        out.append((name, value, (m.group("comment") or "").strip()))
    return out


def table(path):
    lines = ["| parameter | default | meaning (units SI, REP-103) |", "|---|---|---|"]
    for name, value, comment in rows(path):
        lines.append("| `%s` | `%s` | %s |" % (name, value, comment.replace("|", "\\|")))
    return "\n".join(lines) + "\n"


def check(readme, path):
    text = open(readme, encoding="utf-8").read()
    begin = "<!-- generated: scripts/lib/param_table.py %s -->\n" % path
    end = "<!-- end generated -->"
    if begin not in text:
        print("%s: no generated block for %s" % (readme, path))
        return 1
    block = text.split(begin, 1)[1].split(end, 1)[0]
    if block != table(path):
        print("%s: the parameter table of %s is out of date; regenerate it with scripts/lib/param_table.py %s" %
              (readme, path, path))
        return 1
    print("ok: %s holds the table of %s" % (readme, path))
    return 0


def main(argv):
    if len(argv) == 4 and argv[1] == "--check":
        return check(argv[2], argv[3])
    if len(argv) == 2:
        sys.stdout.write(table(argv[1]))
        return 0
    print(__doc__.strip(), file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv))

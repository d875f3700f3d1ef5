#!/usr/bin/python3
"""The documentation against the code (issue 51): docs/monitor.md names every parameter key the
node's parser accepts, every message field of msg/, every topic the node advertises and every
diagnostics status and entry it publishes (each as `name`); docs/library.md's first program is
vadop_core/examples/hello_vadop.cpp verbatim; README.md stays within 200 lines and its links
resolve. The names are read from the sources, not listed here, so a new key, field or entry
without documentation fails this test."""
import glob
import os
import re
import sys
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SNAKE = r'"([a-z][a-z0-9_]*)"'


def read(path):
    with open(os.path.join(ROOT, path)) as f:
        return f.read()


def literal_groups(text, opener):
    """The snake_case string literals of each brace group that follows `opener` (a regex)."""
    out = set()
    for m in re.finditer(opener + r"\s*\{([^{}]*)\}", text):
        out.update(re.findall(SNAKE, m.group(1)))
    return out


def parameter_keys():
    keys = set()
    params = read("vadop_ros/src/params.cpp")
    keys |= literal_groups(params, r"rejectUnknown\(\w+,")
    keys |= literal_groups(params, r"std::set<std::string> keys =")
    for path in glob.glob(os.path.join(ROOT, "vadop_ros/src/sources/*.cpp")):
        text = read(os.path.relpath(path, ROOT))
        keys |= literal_groups(text, r"rejectUnknown\(\w+,")
        keys |= literal_groups(text, r"k\w*Keys =")
        # A source kind: return {"<kind>", {<its keys>}, ...; a body-set kind's name is a top-level key.
        keys |= literal_groups(text, r'return \{"\w+",')
        keys |= set(re.findall(r'BodiesSourceKind \w+\(\) \{\s*return \{"(\w+)"', text))
    return keys


def message_fields():
    fields = set()
    for path in glob.glob(os.path.join(ROOT, "msg/*.msg")):
        with open(path) as f:
            for line in f:
                line = line.split("#", 1)[0].strip()
                if line:
                    fields.add(line.split()[1].split("=")[0])
    return fields


def topics():
    node = read("vadop_ros/src/monitor_node.cpp")
    return set(re.findall(r'advertise<[\w:]+>\("(\w+)"', node))


def diagnostics():
    """Status names and entry keys; a name or key built as "<literal>" + x (or x + "<literal>")
    gives its literal part, which the documentation must show as the start (or end) of a name."""
    node = read("vadop_ros/src/monitor_node.cpp")
    names = set(re.findall(r'updater_\.add\("([\w ]+)"', node))
    entries = set()
    for path in ["vadop_ros/src/monitor_node.cpp", "vadop_ros/src/monitor_diagnostics.cpp"] + [
            os.path.relpath(p, ROOT) for p in glob.glob(os.path.join(ROOT, "vadop_ros/src/sources/*.cpp"))]:
        entries |= set(re.findall(r'\b(?:stat|s)\.add\((?:\w+ \+ )?"([^"]+)"', read(path)))
    return {n.strip() for n in names}, {e.strip() for e in entries}


class Docs(unittest.TestCase):
    def setUp(self):
        self.monitor = read("docs/monitor.md")

    def missing(self, names):
        return sorted(n for n in names if "`%s`" % n not in self.monitor)

    def test_every_parameter_key_is_documented(self):
        keys = parameter_keys()
        self.assertGreater(len(keys), 60, "the parser's keys were not found: %s" % sorted(keys))
        self.assertEqual(self.missing(keys), [], "parameter keys not in docs/monitor.md")

    def test_every_message_field_is_documented(self):
        fields = message_fields()
        self.assertGreater(len(fields), 20)
        self.assertEqual(self.missing(fields), [], "message fields not in docs/monitor.md")

    def test_every_topic_and_diagnostics_entry_is_documented(self):
        names, entries = diagnostics()
        self.assertGreaterEqual(len(topics()), 3)
        self.assertGreater(len(entries), 10)
        self.assertEqual(self.missing(topics() | names | entries), [], "topics / diagnostics not in docs/monitor.md")

    def test_the_library_example_is_the_file(self):
        code = read("vadop_core/examples/hello_vadop.cpp").strip()
        self.assertIn("```cpp\n" + code + "\n```", read("docs/library.md"))

    def test_readme_is_short_and_its_links_resolve(self):
        readme = read("README.md")
        self.assertLessEqual(len(readme.splitlines()), 200)
        for doc in ["README.md"] + [os.path.relpath(p, ROOT) for p in glob.glob(os.path.join(ROOT, "docs/**/*.md"),
                                                                            recursive=True)]:
            base = os.path.dirname(os.path.join(ROOT, doc))
            for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", read(doc)):
                if "://" in target:
                    continue
                self.assertTrue(os.path.exists(os.path.join(base, target)), "%s links to %s" % (doc, target))


if __name__ == "__main__":
    if any(a.startswith("--gtest_output") for a in sys.argv):  # run by catkin: junit result file
        import rosunit
        rosunit.unitrun("vadop", "test_docs", Docs, sys.argv)
    else:
        unittest.main()

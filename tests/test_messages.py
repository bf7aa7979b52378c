"""Messages a student can act on: YAML syntax errors in plain words, case-insensitive name
suggestions, positions inside option values, refusals instead of empty sheets."""

from __future__ import annotations

import pytest

from dynderive.errors import InputError
from dynderive.input.loader import parse_yaml


def _message(text: str) -> str:
    with pytest.raises(InputError) as caught:
        parse_yaml(text, "robot.yaml")
    return str(caught.value)


@pytest.mark.parametrize(("text", "expected"), [
    # a key dedented to the list's dash: PyYAML says "expected <block end>, but found '?'"
    ("links:\n  - name: l1\n    mass: m\n  com: 1\n",
     "robot.yaml:4:3: this line is indented differently from the lines before it (its siblings at column 5)"),
    # dedented between two levels: "expected <block end>, but found '<block mapping start>'"
    ("a:\n    b: 1\n    c: 2\n  d: 3\n",
     "robot.yaml:4:3: this line is indented differently from the lines before it (its siblings at column 5)"),
    # a list item dedented below its siblings
    ("links:\n  - name: l1\n    mass: m\n - name: l2\n",
     "robot.yaml:4:2: this line is indented differently from the lines before it (its siblings at column 3)"),
    # comments and block scalars are no siblings
    ("a:\n  b:\n    # note\n    c: |\n        text\n   d: 2\n",
     "robot.yaml:6:4: this line is indented differently from the lines before it (its siblings at column 5)"),
    # indented more: PyYAML says "mapping values are not allowed here" at the ':'
    ("links:\n  - name: l1\n    mass: m\n      com: 1\n",
     "robot.yaml:4:7: this line is indented more than the line before it (its siblings at column 5)"),
    ("a: 1\n b: 2\n",
     "robot.yaml:2:2: this line is indented more than the line before it (its siblings at column 1)"),
    # "mapping values are not allowed here" on one line
    ("title: Arm: two links\n",
     "robot.yaml:1:11: a second ': ' on this line: a value that contains ': ' must be quoted, or the key "
     "belongs on a line of its own"),
    # "could not find expected ':'": the line without ':' (PyYAML points at the next line)
    ("links:\n  - name: l1\n    mass m\n    com: 1\n",
     "robot.yaml:3:5: this line has no ':' after its key (each line of a mapping is written 'key: value')"),
    ("a:\n  b: 1\n  c\n",
     "robot.yaml:3:3: this line has no ':' after its key (each line of a mapping is written 'key: value')"),
    # a ':' without a space (PyYAML: "could not find expected ':'" or "mapping values ...")
    ("links:\n  - name: l1\n    mass:m\n    com: 1\n",
     "robot.yaml:3:9: put a space after the ':' of 'mass:' (without it YAML reads the key and its value "
     "as one word)"),
    ("a:\n  b:1\n  c: 2\n",
     "robot.yaml:2:4: put a space after the ':' of 'b:' (without it YAML reads the key and its value "
     "as one word)"),
    # tabs: "found character '\t' that cannot start any token"
    ("a:\n  b: 1\n\tc: 2\n", "robot.yaml:3:1: this line is indented with a tab: YAML indentation must use spaces"),
    ("a: [1,\t2]\n", "robot.yaml:1:7: a tab cannot stand here in YAML: use spaces"),
    # a list mixed with keys: "expected <block end>, but found '-'" / "... found '?'"
    ("a:\n  b: 1\n  - c\n",
     "robot.yaml:3:3: list items ('- ...') and 'key: value' lines cannot be mixed at one indentation (column 3)"),
    ("a:\n  - b\n  c: 1\n",
     "robot.yaml:3:3: list items ('- ...') and 'key: value' lines cannot be mixed at one indentation (column 3)"),
])
def test_yaml_syntax_errors_in_student_words(text, expected):
    assert _message(text) == expected


def test_other_yaml_errors_keep_pyyaml_wording():
    assert _message("a: *x\n") == "robot.yaml:1:4: YAML syntax error: found undefined alias 'x'"

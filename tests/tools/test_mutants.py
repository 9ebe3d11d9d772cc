"""tools/mutate.py's mutants stay applicable: each rule's text is found exactly once in its file
(an edit of the code that moves a rule would otherwise stop the mutation run at that mutant),
each mutated file still compiles (a mutant that breaks the indentation stops the run too), and
each names a test that exists."""

from pathlib import Path

from tools import mutate

ROOT = Path(__file__).resolve().parents[2]


def test_every_mutant_text_is_found_exactly_once():
    missing = [name for name, rel, original, _mutated, _test in mutate.MUTANTS
               if (ROOT / rel).read_text().count(original) != 1]
    assert missing == []


def test_every_mutant_names_an_existing_test():
    for name, _rel, _original, _mutated, test in mutate.MUTANTS:
        path, _, func = test.partition("::")  # a test, or a whole test file
        source = (ROOT / path).read_text()
        assert not func or f"def {func.split('[')[0]}(" in source, name


def test_every_mutant_compiles():
    broken = []
    for name, rel, original, mutated, _test in mutate.MUTANTS:
        source = (ROOT / rel).read_text().replace(original, mutated, 1)
        try:
            compile(source, rel, "exec")
        except SyntaxError:
            broken.append(name)
    assert broken == []

"""A number in a page's prose comes from the results, or says it is the paper's.

The rule (issue 44, "numbers in prose come from the results"). In a page's Markdown -- the
Markdown cells of ``notebooks/*.md`` and the hand-written pages ``book/*.md`` -- a
**decimal number** (digits, a point, digits: ``94.55``, ``0.1``) must be one of:

* **produced from the page's data**: a glue role (``{glue:text}`key:.2f```, also across
  pages as ``generated/<page>.ipynb::key``), or text printed by a code cell (a sentence
  function of ``uavwind``, tested there, whose output the page shows as Markdown). Code
  cells are not read here: what they print is computed;
* **marked as the paper's**: the ``{abbr}`` role with the source in parentheses,
  ``{abbr}`94.55 (paper)```. It renders as the number with a tooltip naming the source. Two
  sources are allowed: ``paper`` (a value the paper prints: a table cell, a constant of its
  model, the NWS ranges it quotes) and ``input`` (a value that is *given*, not computed
  here: a published vehicle's mass, a setting of a cited implementation, a setting of this
  project or of an exercise). A result this project computed is never ``input``: it is
  glued, and so is a setting the library holds as a constant (``uw.CONSUMER_NOISE``), so
  the prose follows the constant;
* **not prose**: inside math (``$...$``, ``$$...$$``, a ``{math}`` block: the model's
  equations, their constants and what they give at stated inputs, such as
  $0.1 \times 12 = 1.2$), inline code or a code block, a link's target, a
  directive's option lines (``:label:``), a version string (``rotorpy 3.0.0``: a name).

**Integer results too** (issue 67). An integer that is a *result* -- a percentage (``83%``,
``83 percent``), a count out of a total (``5 of 5``, ``3 out of 4``, ``4/5``) or a count of
outcomes (``12 loops grouped correctly``, ``3 pairs separate``, ``2 verdicts change``) -- obeys
the same rule as a decimal: glued, printed by a code cell, or marked ``{abbr}`80% (input)```.
Most whole numbers in prose are not results, and these are allowed, each by name
(:data:`INTEGER_EXCEPTIONS`):

* **labels**: experiment, table, figure, section, equation, exercise, decision, issue and
  round numbers (``Exp 13``, ``Tables 5-7``, ``eqs 2-8``, ``Exercise 20``), claim and scenario
  ids (``C3``, ``S1``: a letter and a number are one word);
* **years** (``2024``) and **citations** (a ``{cite}`` role is not prose);
* **the confidence level** ``95%`` of an interval (``95% CI``, ``95% bootstrap interval``,
  ``95% t interval``, ``95% confidence``, ``the 95% level``): the level asked for, not found;
* **settings and inputs written as such**: a number of the paper or of a setting that is not
  a percentage, a total or a count of outcomes (``50 loops``, ``12 s``, ``10 environments per
  group``) is not read; a percentage or total that is an input is marked ``(input)`` or
  ``(paper)`` like a decimal.

A Markdown cell that breaks the rule fails this test with the page, the line and the
number; ``test_a_planted_bare_number_is_caught`` and
``test_a_planted_integer_result_is_caught`` show the checker catching one of each.
"""
from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.md"))
BOOK_PAGES = sorted((ROOT / "book").glob("*.md"))

#: The sources a marked number may name: ``{abbr}`94.55 (paper)```.
SOURCES = ("paper", "input")

_DECIMAL = re.compile(r"(?<![\w.])\d+\.\d+(?!\w|\.\d)")  # not a version: 3.0.0
_FENCE = re.compile(r"^(\s*)(`{3,}|~{3,}|:{3,})\s*(\{(?P<name>[\w:-]+)\})?")
# directives whose body is code or math, not prose
_CODE_DIRECTIVES = {"code-cell", "code-block", "code", "math", "raw", "eval-rst"}
_ABBR = re.compile(r"\{abbr\}`([^`]*)`")
_ROLE = re.compile(r"\{[\w:.-]+\}`[^`]*`")
_INLINE_CODE = re.compile(r"(`+)(?:(?!\1).)+?\1", re.S)
_DISPLAY_MATH = re.compile(r"\$\$.+?\$\$", re.S)
_INLINE_MATH = re.compile(r"(?<!\\)\$(?:[^$\n]|\n(?!\s*\n))+?(?<!\\)\$")
_LINK_TARGET = re.compile(r"\]\([^)]*\)|<https?://[^>]*>|https?://\S+")
_COMMENT = re.compile(r"<!--.*?-->", re.S)


def _blank(match: re.Match) -> str:
    """A removed span keeps its line breaks, so line numbers stay right."""
    return re.sub(r"[^\n]", " ", match.group(0))


def _prose(markdown: str) -> str:
    """``markdown`` with everything that is not prose blanked: code and math blocks,
    directive headers and options, roles (a marked ``{abbr}`` too), inline code and math,
    link targets and comments."""
    out, stack = [], []  # stack of (fence, is_code)
    for line in markdown.splitlines():
        m = _FENCE.match(line)
        if m and stack and m.group(2)[0] == stack[-1][0][0] and len(m.group(2)) >= len(stack[-1][0]) \
                and not line.strip()[len(m.group(2)):].strip():
            stack.pop()
            out.append("")
            continue
        if m and (m.group(3) or not stack or not stack[-1][1]) and (m.group(3) or m.group(2)[0] != ":"):
            name = m.group("name")
            stack.append((m.group(2), name is None or name in _CODE_DIRECTIVES))
            out.append("")
            continue
        if stack and stack[-1][1]:
            out.append("")
            continue
        if stack and re.match(r"^\s*:[\w-]+:", line):  # a directive's option line
            out.append("")
            continue
        out.append(line)
    text = "\n".join(out)
    text = _COMMENT.sub(_blank, text)
    text = _DISPLAY_MATH.sub(_blank, text)

    def abbr(m: re.Match) -> str:
        inner = re.match(r"(.*)\(([^()]*)\)\s*$", m.group(1), re.S)
        if inner and inner.group(2).strip() in SOURCES:
            return _blank(m)
        return " " + m.group(1) + " "  # not a mark: its numbers are read
    text = _ABBR.sub(abbr, text)
    text = _ROLE.sub(_blank, text)
    text = _INLINE_CODE.sub(_blank, text)
    text = _INLINE_MATH.sub(_blank, text)
    text = _LINK_TARGET.sub(_blank, text)
    return text


#: The integers in prose that are not results, each allowed by name (see the module's doc).
INTEGER_EXCEPTIONS = {
    "label": re.compile(r"\b(?:Exps?|Experiments?|Tables?|Figs?|Figures?|[Ss]ections?|§|eqs?|"
                        r"[Ee]quations?|Exercises?|[Dd]ecisions?|[Ii]ssues?|[Rr]ounds?|"
                        r"[Ss]essions?|[Ss]cenarios?|[Cc]laims?)\.?\s*$"),
    "year": re.compile(r"^(?:19|20)\d\d$"),
    "confidence level": re.compile(r"^\s*(?:bootstrap\s+|Student\s+|two-sided\s+|one-sided\s+)?"
                                   r"(?:t\s+)?(?:lower\s+|upper\s+)?(?:CIs?|confidence|intervals?|level|bound)\b"),
}

#: An integer result: a percentage, a count out of a total, or a count of outcomes.
_PERCENT = re.compile(r"(?<![\w.,])(\d+)\s?(?:%|percent\b|per cent\b)")
_OF_TOTAL = re.compile(r"(?<![\w.,])(\d+)\s+(?:out\s+)?of\s+(?:the\s+|its\s+|their\s+)?\d+\b"
                       r"|(?<![\w.,/])(\d+)/\d+(?![\w/.])")
_OUTCOMES = (r"grouped|group(?:s)?\s+correctly|separat(?:e|es|ed)|decid(?:e|es|ed)|reproduc(?:e|es|ed)|"
             r"crash(?:ed|es)?|flipped|fail(?:s|ed)?|chang(?:e|es|ed)|agree(?:s|d)?|misgroup\w*|"
             r"pass(?:es|ed)?")
_COUNT_OF = re.compile(r"(?<![\w.,])(\d+)\s+(?:\w+\s+){0,2}?(?:loops?|pairs?|cases?|cells?|"
                       r"scenarios?|channels?|controllers?|episodes?|flights?|verdicts?|claims?|"
                       r"environments?|runs?|settings?)\s+(?:\w+\s+){0,1}?(?:" + _OUTCOMES + r")\b")


def _integer_results(line: str) -> list[str]:
    """The integer results in one line of prose, less :data:`INTEGER_EXCEPTIONS`; a number
    is reported once, in the first phrase that holds it."""
    found, seen = [], set()
    for rx in (_PERCENT, _OF_TOTAL, _COUNT_OF):
        for m in rx.finditer(line):
            g = next(i for i in range(1, (m.lastindex or 0) + 1) if m.group(i))
            num, start = m.group(g), m.start(g)
            if start in seen:
                continue
            seen.add(start)
            if INTEGER_EXCEPTIONS["label"].search(line[:start]):
                continue
            if INTEGER_EXCEPTIONS["year"].match(num):
                continue
            if rx is _PERCENT and num == "95" and INTEGER_EXCEPTIONS["confidence level"].match(
                    line[m.end():]):
                continue
            found.append(m.group(0).strip())
    return found


def bare_numbers(markdown: str) -> list[tuple[int, str, str]]:
    """Every decimal number and every integer result (a percentage, a count out of a total,
    a count of outcomes) in the prose of ``markdown`` that is neither computed (glue) nor
    marked (``{abbr}`x (paper)```) nor one of :data:`INTEGER_EXCEPTIONS`, as (line number
    from 1, the number or the phrase holding it, line)."""
    if not isinstance(markdown, str):
        raise ValueError(f"markdown must be a str, got {type(markdown).__name__}")
    lines = markdown.splitlines()
    out = []
    for i, line in enumerate(_prose(markdown).splitlines()):
        hits = [(m.start(), m.group(0)) for m in _DECIMAL.finditer(line)]
        hits += [(line.find(r), r) for r in _integer_results(line)]
        out += [(i + 1, num, lines[i].strip()) for _, num in sorted(hits)]
    return out


def markdown_cells(path: Path) -> list[str]:
    """The Markdown of a page: each Markdown cell of a notebook, or a book page whole."""
    if path.parent.name != "notebooks":
        return [path.read_text()]
    import jupytext
    return [c.source for c in jupytext.read(path).cells if c.cell_type == "markdown"]


def page_bare_numbers(path: Path) -> list[str]:
    return [f"{path.relative_to(path.parents[1])}: {num!r} in {line!r}"
            for cell in markdown_cells(path) for _, num, line in bare_numbers(cell)]


# -- the checker itself ---------------------------------------------------------------

@pytest.mark.parametrize("text", [
    "The mean score is 94.12 over five loops.",
    "light 0.45-1.34 m/s",
    "a spike of about 6.0 nats",
    "the score ends the sentence at 94.55.",
    "{abbr}`94.55 (the authors)` is not a source the rule knows",
    "```{exercise}\n:label: ex-a\n\nScores 83.2 here.\n```",
    ":::{note}\nA note that says 1.5 m.\n:::",
])
def test_the_checker_flags_a_bare_decimal(text):
    assert bare_numbers(text), text


@pytest.mark.parametrize("text", [
    "The paper reports {abbr}`94.55 (paper)`.",
    "NWS ranges ({abbr}`0.45-1.34 m/s (paper)`), a data sheet's {abbr}`2.1 m (input)`.",
    "mean {glue:text}`fit_mean_1:.2f` and {glue:text}`generated/inference.ipynb::x:.1f`",
    "with $\\alpha = 0.143$ and $$U = 1.5 z$$",
    "call `uw.Noise(position=0.21)` first",
    "```python\nx = 0.5\n```",
    "```{code-cell} ipython3\nprint(0.5)\n```",
    "```{math}\n\\sigma = 0.1 W_{20}\n```",
    "see [v1.2](https://example.org/v1.2.3) and section 4, Table 4, Exp 13, 2024, 50 loops",
    "```{exercise}\n:label: ex-0.5\n:class: 1.5\n\nNo decimal here.\n```",
    "RotorPy 3.0.0's quadrotor",
])
def test_the_checker_passes_what_the_rule_allows(text):
    assert bare_numbers(text) == [], text


@pytest.mark.parametrize("text", [
    "5 of 5 loops grouped correctly",
    "it groups 83% of the loops correctly",
    "the clustering separates 3 out of 4 pairs",
    "4/5 controllers agree",
    "12 loops grouped correctly and the rest did not",
    "2 verdicts change at 30 loops",
    "only 3 light pairs separate",
    "a score of 40 percent",
    "{abbr}`83% (the authors)` is not a source the rule knows",
])
def test_the_checker_flags_an_integer_result(text):
    assert bare_numbers(text), text


@pytest.mark.parametrize("text", [
    "Exp 13 and Exps 13-14, Table 4, Tables 5-7, Fig 4, section 12, eqs 2-8, Exercise 20",
    "Exercises 23 of 24 name none",   # a label, not a count
    "in 2024 the authors wrote",
    "bootstrap 95% confidence intervals; a 95% CI; the 95% level; its 95% t interval",
    "the exact one-sided 95% lower bound of the share",
    "50 loops per case over 12 s with 10 environments per group",
    "a UAV {abbr}`20% (input)` heavier, {glue:text}`share:.0f`% of the loops",
    "claim C3 and scenario S1 (scenarios 1 and 4)",
    "{cite:p}`alwalan2024` 5 of",
])
def test_the_checker_allows_the_named_integer_exceptions(text):
    assert bare_numbers(text) == [], text


def test_the_checker_names_the_line_and_number():
    found = bare_numbers("one\n\nThe IMU scores 83.2,\nand $x = 1.5$ then 0.7.")
    assert [(n, num) for n, num, _ in found] == [(3, "83.2"), (4, "0.7")]


def test_the_checker_rejects_a_non_string():
    with pytest.raises(ValueError, match="markdown"):
        bare_numbers(None)


def test_a_planted_bare_number_is_caught(tmp_path):
    """A copy of a real page passes; the same copy with one hand-typed result fails."""
    page = tmp_path / "notebooks" / "exp1_wind_speed.md"
    page.parent.mkdir()
    shutil.copy(ROOT / "notebooks" / "exp1_wind_speed.md", page)
    assert page_bare_numbers(page) == []
    text = page.read_text()
    head, sep, tail = text.partition("\n## ")
    assert sep, "the page has a section to plant the sentence in"
    page.write_text(head + sep + tail.replace("\n", "\n\nThe mean score is 86.71 here.\n", 1))
    found = page_bare_numbers(page)
    assert len(found) == 1 and "86.71" in found[0], found


def test_a_planted_integer_result_is_caught(tmp_path):
    """The same copy with a hand-typed count and percentage fails: integers are results too."""
    page = tmp_path / "notebooks" / "exp1_wind_speed.md"
    page.parent.mkdir()
    shutil.copy(ROOT / "notebooks" / "exp1_wind_speed.md", page)
    assert page_bare_numbers(page) == []
    text = page.read_text()
    head, sep, tail = text.partition("\n## ")
    page.write_text(head + sep + tail.replace(
        "\n", "\n\nHere 5 of 5 loops grouped correctly, 83% of the paper's.\n", 1))
    found = page_bare_numbers(page)
    assert len(found) == 2 and "5 of 5" in found[0] and "83%" in found[1], found


# -- the book's own pages -------------------------------------------------------------

@pytest.mark.parametrize("path", NOTEBOOKS + BOOK_PAGES, ids=lambda p: p.name)
def test_no_bare_decimal_in_a_pages_prose(path):
    found = page_bare_numbers(path)
    assert found == [], ("a number or integer result typed into prose: glue it from the "
                         "results, or mark it "
                         "{abbr}`x (paper)` / {abbr}`x (input)`:\n" + "\n".join(found))


# --------------------------------------------------------------------------- #
# a solution's code is the code a reader can run: every name it uses is defined or imported
# in its own cells (issue 44: eleven solutions used the page's hidden `np`, `uw`, ...)
# --------------------------------------------------------------------------- #
#: Names a solution may take from its page, each saying so in a comment where it is used.
PAGE_NAMES = {("inference.md", "ex-fit-target"): {"fit_results"},
              # the inference page's scale check at the page's own profile and seed
              ("exp1_wind_speed.md", "ex-scale-invariance"): {"profile", "seed"}}


def _undefined_names(code: str) -> set[str]:
    import ast
    import builtins

    tree = ast.parse(code)
    defined, used = set(dir(builtins)), set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            defined |= {(a.asname or a.name).split(".")[0] for a in node.names}
        elif isinstance(node, ast.Name):
            (defined if isinstance(node.ctx, ast.Store) else used).add(node.id)
        elif isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            defined.add(node.name)
        elif isinstance(node, ast.arg):
            defined.add(node.arg)
        elif isinstance(node, ast.ExceptHandler) and node.name:
            defined.add(node.name)
    return used - defined


def _solutions(text: str):
    """(label, [(tags, code)]) of every solution block of a MyST page."""
    for m in re.finditer(r"```\{solution-start\}\s*(\S+)(.*?)```\{solution-end\}", text, re.S):
        cells = [(c.group(1), c.group(2)) for c in re.finditer(
            r"```\{code-cell\}[^\n]*\n((?::tags:[^\n]*\n)?)(.*?)```", m.group(2), re.S)]
        yield m.group(1), cells


def test_the_solution_checker_finds_a_hidden_name():
    page = ("```{solution-start} ex-a\n```\n\n```{code-cell} ipython3\nx = np.ones(2)\n```\n\n"
            "```{solution-end}\n```\n")
    (label, cells), = _solutions(page)
    assert label == "ex-a" and _undefined_names(cells[0][1]) == {"np"}
    assert _undefined_names("import numpy as np\nx = np.ones(2)\n") == set()


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_every_solution_imports_what_it_uses(path):
    for label, cells in _solutions(path.read_text()):
        defined_here = "\n".join(code for _, code in cells)
        shown = "\n".join(code for tags, code in cells if "remove-input" not in tags)
        # names a later (hidden) cell reads from an earlier shown one count as defined
        missing = _undefined_names(shown) & _undefined_names(defined_here) \
            - PAGE_NAMES.get((path.name, label), set())
        assert not missing, (f"{path.name} {label}: its code uses {sorted(missing)} without "
                             "importing or defining them (a reader's fresh kernel fails)")

"""The flake census counts every red run and names the failing test with its first assertion line; a run that
reports nothing counts as red."""

from __future__ import annotations

from pathlib import Path

from flakes.census import census, table


def test_a_census_counts_red_runs_and_names_the_failing_test_with_its_assertion(tmp_path: Path) -> None:
    flaky = tmp_path / "test_flaky.py"
    flaky.write_text("import os\n\n"
                     "def test_steady():\n    assert True\n\n"
                     "def test_flaky():\n"
                     f"    marker = {str(tmp_path / 'ran')!r}\n"
                     "    first = not os.path.exists(marker)\n"
                     "    open(marker, 'a').close()\n"
                     "    assert not first, 'red on the first run only'\n")
    broken = tmp_path / "test_broken.py"
    broken.write_text("import nothing_of_that_name\n")
    tallies = census([str(flaky), str(broken)], [], runs=2, suites=0, echo=False)
    assert (tallies[str(flaky)].runs, tallies[str(flaky)].failed_runs) == (2, 1)
    [((test, line), times)] = tallies[str(flaky)].failures.items()
    assert test == "test_flaky::test_flaky" and "red on the first run only" in line and times == 1
    assert tallies[str(broken)].failed_runs == 2  # collection failed: red, never "nothing to see"
    text = table(tallies)
    assert text.endswith("flakes: 4 runs, 3 failed") and "red on the first run only" in text

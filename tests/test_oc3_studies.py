"""The study registry and ``kanedyn study``: listing, bad names and options (exit 2)."""

import pytest

from kanedyn._errors import KanedynError
from kanedyn.analysis import STUDIES, StudyOption, run_study
from kanedyn.analysis._studies import study_option_value
from kanedyn.cli._main import main


def test_listing_names_the_oc3_studies(capsys):
    assert main(["study"]) == 0
    text = capsys.readouterr().out
    assert "oc3-decay:" in text and "oc3-rao:" in text and "check_periods=" in text
    assert {"oc3-decay", "oc3-rao"} <= set(STUDIES)


@pytest.mark.parametrize("argv", [["study", "no-such-study"],
                                  ["study", "oc3-rao", "--set", "bogus=1"],
                                  ["study", "oc3-rao", "--set", "n_periods=two"],
                                  ["study", "oc3-rao", "--set", "backend=fortran"],
                                  ["study", "oc3-rao", "--set", "novalue"]])
def test_bad_study_input_exits_2_with_one_line(argv, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("kanedyn: error:") and err.count("\n") == 1


def test_option_values_are_converted_never_evaluated():
    opt = StudyOption(bool, True)
    assert study_option_value("s", "drag", opt, "off") is False
    assert study_option_value("s", "n", StudyOption(int, 1), "12") == 12
    with pytest.raises(KanedynError, match="option n must be int"):
        study_option_value("s", "n", StudyOption(int, 1), "__import__('os')")
    with pytest.raises(KanedynError, match="unknown study"):
        run_study("nope")

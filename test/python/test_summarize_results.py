"""The closing line of scripts/test (ccir_mapping.summarize_results): every gtest and rostest
case counted once, a rostest's own file only when it failed, and a failure when nothing ran."""
from ccir_mapping.summarize_results import main

GTEST = """<testsuites><testsuite name="s">
<testcase classname="A" name="passes"/>
<testcase classname="A" name="fails"><failure message="expected 1, got 2"/></testcase>
<testcase classname="A" name="skips"><skipped/></testcase>
</testsuite></testsuites>"""
ROSTEST_OK = """<testsuite><testcase classname="rostest" name="ran"/></testsuite>"""
ROSTEST_FAILED = """<testsuite><testcase classname="rostest" name="crashed">
<error message="test node died"/></testcase></testsuite>"""


def test_counts_each_case_once_and_fails_on_a_failure(tmp_path, capsys):
    (tmp_path / "gtest-ccir_mapping_common_tests.xml").write_text(GTEST)
    (tmp_path / "rostest-test_rostest_pipeline_pipeline.xml").write_text(ROSTEST_OK)
    assert main([str(tmp_path)]) == 1
    lines = capsys.readouterr().out.splitlines()
    assert lines[-1] == "1 passed, 1 failed, 1 skipped"
    assert any("failed: A.fails: expected 1, got 2" in line for line in lines)
    assert not any("rostest-test_rostest_pipeline_pipeline" in line for line in lines)


def test_a_crashed_rostest_counts_and_an_unreadable_file_fails(tmp_path, capsys):
    (tmp_path / "rostest-test_rostest_team_team_map.xml").write_text(ROSTEST_FAILED)
    (tmp_path / "rosunit-broken.xml").write_text("<testsuite>")
    assert main([str(tmp_path)]) == 1
    assert capsys.readouterr().out.splitlines()[-1] == "0 passed, 2 failed, 0 skipped"


def test_passes_only_when_something_ran(tmp_path, capsys):
    assert main([str(tmp_path)]) == 1
    (tmp_path / "gtest-x.xml").write_text(
        '<testsuite><testcase classname="A" name="passes"/></testsuite>')
    assert main([str(tmp_path)]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == "1 passed, 0 failed, 0 skipped"

"""Summarises the JUnit XML files of one test run (or of several rounds, a directory each): a
line per suite, then the closing line 'N passed, N failed, N skipped'. Exits 1 on any failure
or when no test ran.

rostest writes two files per test: rosunit-<name>.xml (the test node's own gtest cases) and
rostest-<...>.xml (whether the node ran and reported). The second is counted only when it
failed, e.g. when the node crashed or hit its time limit, so no case is counted twice.
"""
import glob
import os
import sys
import xml.etree.ElementTree as ET


def cases(path):
    root = ET.parse(path).getroot()
    for case in root.iter("testcase"):
        failure = case.find("failure")
        if failure is None:
            failure = case.find("error")
        if failure is not None:
            text = (failure.get("message") or failure.text or "").strip().splitlines()
            yield "failed", "%s.%s" % (case.get("classname"), case.get("name")), (text or [""])[0]
        elif case.find("skipped") is not None or case.get("result") == "skipped":
            yield "skipped", case.get("name"), ""
        else:
            yield "passed", case.get("name"), ""


def main(results_dirs):
    totals = {"passed": 0, "failed": 0, "skipped": 0}
    files = [path for d in results_dirs for path in sorted(glob.glob(os.path.join(d, "*.xml")))]
    for path in files:
        name = os.path.basename(path)[:-4]
        if len(results_dirs) > 1:
            name = os.path.basename(os.path.dirname(path)) + "/" + name
        counts = {"passed": 0, "failed": 0, "skipped": 0}
        failures = []
        try:
            for outcome, case, message in cases(path):
                counts[outcome] += 1
                if outcome == "failed":
                    failures.append((case, message))
        except ET.ParseError as error:
            counts["failed"] += 1
            failures.append((name, "unreadable result file: %s" % error))
        if os.path.basename(path).startswith("rostest-"):
            if not counts["failed"]:
                continue
            counts["passed"] = counts["skipped"] = 0
        for key in totals:
            totals[key] += counts[key]
        status = "FAIL" if counts["failed"] else "ok  "
        print("%s %-58s %3d passed, %d failed, %d skipped"
              % (status, name, counts["passed"], counts["failed"], counts["skipped"]))
        for case, message in failures:
            print("       failed: %s: %s" % (case, message[:200]))
    print("%d passed, %d failed, %d skipped"
          % (totals["passed"], totals["failed"], totals["skipped"]))
    ran = totals["passed"] + totals["failed"]
    return 0 if ran and not totals["failed"] else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

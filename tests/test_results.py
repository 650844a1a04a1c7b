"""The test driver counts tests from the runners' own closing lines; a misread count would hide
failures or make CI think no test ran."""
from r2ptools import results


def test_libtest_sums_every_binary():
    out = (
        "test result: ok. 12 passed; 0 failed; 1 ignored; 0 measured; 0 filtered out\n"
        "noise\n"
        "test result: FAILED. 3 passed; 2 failed; 0 ignored; 0 measured; 0 filtered out\n"
        "test result: ok. 0 passed; 0 failed; 0 ignored; 0 measured; 0 filtered out\n"
    )
    c = results.libtest(out)
    assert (c.passed, c.failed, c.skipped) == (15, 2, 1)


def test_libtest_reads_the_qemu_runner():
    c = results.libtest("test result: FAILED. 1 passed; 1 failed\n")
    assert (c.passed, c.failed) == (1, 1)


def test_pytest_closing_line_plain_and_decorated():
    c = results.pytest("....\n3 passed, 1 failed, 2 skipped in 1.20s\n")
    assert (c.passed, c.failed, c.skipped) == (3, 1, 2)
    c = results.pytest("===== 1 failed, 7 passed, 1 error, 2 warnings in 0.5s =====\n")
    assert (c.passed, c.failed, c.skipped) == (7, 2, 0)


def test_pytest_with_no_closing_line_counts_nothing():
    c = results.pytest("ERROR: file or directory not found: nowhere\n")
    assert c.total == 0

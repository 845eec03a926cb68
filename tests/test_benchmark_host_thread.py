"""The benchmark's --as-qgis mode runs a case on a thread of its own, as QGIS runs an algorithm."""
import threading

import pytest

from benchmarks.run import _on_a_host_thread


def test_a_case_runs_on_another_thread_and_its_result_or_error_comes_back():
    assert _on_a_host_thread(lambda: threading.current_thread().name) == "host-task"
    assert _on_a_host_thread(sum, [1, 2, 3]) == 6
    with pytest.raises(ValueError, match="bad case"):
        _on_a_host_thread(lambda: (_ for _ in ()).throw(ValueError("bad case")))

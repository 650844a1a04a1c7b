"""The gateway's CPU and memory figures in `make bench` (scripts/r2ptools/bench.py): its work per
event counted under QEMU on the F407's core, the same counts every run, and the CPU share at its
default rates made of them."""
import functools

import pytest

from r2ptools import bench

EVENTS = ("base_step_insn", "base_ik_step_insn", "gateway_step_insn", "handover_insn",
          "ros_poll_idle_insn", "ros_odom_insn", "ros_cmd_vel_insn", "can_frame_to_client_insn")


@pytest.fixture(scope="module")
def counts():
    return functools.cache(bench.gateway_cpu)()


def test_every_event_is_counted_and_the_counts_repeat(counts):
    assert counts["euler_filter_insn"] > 0
    for key in EVENTS:
        assert counts[key] > 0, key
    # A step with the IK does more than the mean step; the longest is at least the IK's.
    assert counts["base_step_max_insn"] >= counts["base_ik_step_insn"] > counts["base_step_insn"]
    # One second of the ROS task: a poll every 5 ms, each topic at its rate (ros.rs's TOPICS:
    # 20 + 1 + 4 × 10 + 50 + 1 + 10 + 10 + 5 samples).
    assert (counts["ros_per_second_polls"], counts["ros_per_second_samples"]) == (200, 137)
    assert counts["ros_per_second_insn"] > 200 * counts["ros_poll_idle_insn"]
    assert bench.gateway_cpu() == counts, "-icount: the same image counts the same"


def test_the_cpu_share_is_made_of_the_counts_at_the_default_rates(counts):
    rows = dict(bench.gateway_load(counts, 1_000))
    app, ros, can = rows.values()
    assert app == 1_000 * (counts["gateway_step_insn"] + counts["base_step_insn"]
                           + counts["handover_insn"])
    assert ros == counts["ros_per_second_insn"] + 20 * counts["ros_cmd_vel_insn"]
    assert can == 1_000 * counts["can_frame_to_client_insn"]
    assert list(dict(bench.gateway_load(counts, 2_000)).values())[2] == 2 * can


def test_the_report_states_a_lower_bound_and_the_image(counts, capsys):
    bench.report_gateway(counts, 1_432.5)
    out = capsys.readouterr().out
    assert "STM32F407 at 168 MHz" in out and "1,432 bus frames/s to one client" in out
    assert "lower bound" in out and "on a full bus (7,634 frames/s)" in out
    assert "gateway image: flash" in out and "heap none" in out


def test_a_heap_in_the_image_is_not_reported_as_none(tmp_path):
    assert bench.gateway_heap() == 0
    (tmp_path / "main.rs").write_text("#[global_allocator]\nstatic HEAP: Heap = Heap::empty();\n")
    with pytest.raises(RuntimeError, match="sets a global allocator"):
        bench.gateway_heap(tmp_path)

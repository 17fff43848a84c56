"""The port scheme (mavsim_core.ports) and the table of test instance numbers (tests/instances.py)."""

from __future__ import annotations

from pathlib import Path

from mavsim_core import ports as port_scheme

from instances import BENCHMARKS, INSTANCES, PEOPLE, all_instances, collisions, instance, ports

TESTS = Path(__file__).resolve().parent
EVERY_INSTANCE = range(port_scheme.MAX_INSTANCE + 1)


def test_ports_of_an_instance_follow_px4():
    """PX4 SITL instance 3: system id 4, TCP 4563, API link to 14543, ground-station link from 18573 to 14550."""
    assert port_scheme.system_id(3) == 4
    assert port_scheme.sim_tcp_port(3) == 4563
    assert port_scheme.api_port(3) == 14543
    assert port_scheme.gcs_local_port(3) == 18573
    assert port_scheme.GCS_PORT == 14550
    assert ports(3) == {("tcp", 4563), ("udp", 18573), ("udp", 14643), ("udp", 14543), ("udp", 14743), ("udp", 14843)}


def test_no_two_instances_0_to_99_share_a_port():
    """Every pair of instances 0-99: nothing bound by one (itself or its clients) is bound by the other."""
    assert collisions(list(EVERY_INSTANCE)) == []


def test_only_instance_10_sends_its_api_link_to_the_shared_ground_station_port():
    """PX4's own overlap: 14540+10 = 14550.  No other port of any instance is 14550."""
    on_14550 = [i for i in EVERY_INSTANCE if ("udp", port_scheme.GCS_PORT) in ports(i)]
    assert on_14550 == [10]


def test_every_test_instance_is_distinct_and_in_range():
    numbers = [i for _, _, i in all_instances()]
    assert len(numbers) == len(set(numbers)), "an instance number is used twice"
    assert all(0 <= i <= port_scheme.MAX_INSTANCE for i in numbers)


def test_test_instances_keep_clear_of_people_benchmarks_and_10():
    numbers = {i for _, _, i in all_instances()}
    assert not numbers & {*PEOPLE, *BENCHMARKS, 10}


def test_lookup():
    assert instance("test_e2e_flight", "shared") == INSTANCES["test_e2e_flight"]["shared"]


def test_every_file_in_the_table_exists_and_uses_it():
    """Each file named in the table exists and reads its numbers from it."""
    for name in INSTANCES:
        assert "from instances import" in (TESTS / f"{name}.py").read_text(), name

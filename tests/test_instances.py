"""The table of test instance numbers (tests/instances.py) has no two instances sharing a port."""

from __future__ import annotations

from pathlib import Path

from instances import BENCHMARKS, INSTANCES, PEOPLE, all_instances, collisions, instance, ports

TESTS = Path(__file__).resolve().parent


def test_ports_of_an_instance():
    assert ports(3) == {("tcp", 4563), ("udp", 14543), ("udp", 14553), ("udp", 14563), ("udp", 14583), ("udp", 18573)}


def test_collision_rule_is_the_differences_10_to_40():
    """The reason for the table: 10, 20, 30 and 40 apart share a UDP port, anything else does not."""
    for d in range(1, 100):
        assert bool(collisions([100, 100 + d])) == (d in (10, 20, 30, 40)), d
    assert collisions([5, 15]) == [(5, 15, {("udp", 14555), ("udp", 14565)})]  # 14550+5 = 14540+15, 14560+5 = 14550+15


def test_every_test_instance_is_collision_free():
    numbers = [i for _, _, i in all_instances()]
    assert len(numbers) == len(set(numbers)), "an instance number is used twice"
    assert collisions(numbers) == []


def test_test_instances_keep_clear_of_people_and_benchmarks():
    numbers = [i for _, _, i in all_instances()]
    for other in (*PEOPLE, *BENCHMARKS):
        for i in numbers:
            assert not ports(i) & ports(other), (i, other)


def test_lookup():
    assert instance("test_e2e_flight", "shared") == INSTANCES["test_e2e_flight"]["shared"]


def test_every_file_in_the_table_exists_and_uses_it():
    """Each file named in the table exists and reads its numbers from it."""
    for name in INSTANCES:
        assert "from instances import" in (TESTS / f"{name}.py").read_text(), name

"""The simulated bus on a busy computer: nothing slow sits on its reply path, and nothing heavy
runs under a real-time class where it would starve other runs' buses (issue 47).

A ``biped excite`` stopped with "servo 200: ... no good reply for 102 ms" while two other dry
runs started beside it: their simulated buses built and compiled MuJoCo models, and locked
their memory, under SCHED_FIFO, and this run's bus waited 235 ms for a core.  The checks here
are of order and amount, never of time (timing belongs in ``benchmarks/simbus_latency.py``).
"""

from __future__ import annotations

import argparse
import functools
import gc
import os
import time

import pytest

from sim2real.hardware import MockBus, realtime
from sim2real.hardware.deploy import drive
from sim2real.hardware.loop import READ_BUDGET, TICK_ATTEMPTS, read_budget
from sim2real.hardware.dynamixel.sdk_bus import DynamixelBus
from sim2real.robot import load_robot
from sim2real.simulation.simbus import service
from sim2real.simulation.simbus import protocol2 as p2
from sim2real.simulation.simbus.physics import REPLY_CATCH_UP_S, PhysicsChain
from sim2real.simulation.simbus.server import EmulatedChain, PtyServer

ROBOT = load_robot()


def test_after_a_stall_a_reply_waits_for_one_chunk_of_physics_and_the_rest_is_caught_up_between():
    now = [0.0]
    physics = PhysicsChain(ROBOT, clock=lambda: now[0])
    chain = EmulatedChain(physics.devices, clock=lambda: now[0],
                          advance=functools.partial(physics.advance, REPLY_CATCH_UP_S))
    step = physics.model.opt.timestep
    now[0] = 0.2  # the host stalled 200 ms
    chain.handle(1, p2.PING, b"")
    assert physics.data.time == pytest.approx(REPLY_CATCH_UP_S)  # not 0.2: the reply did not wait for it all
    chunks = 0
    while chain.tick():
        chunks += 1
        assert chunks < 100
    assert physics.data.time == pytest.approx(0.2, abs=step)
    assert chunks == round((0.2 - REPLY_CATCH_UP_S) / REPLY_CATCH_UP_S) - 1  # the last chunk says "caught up"
    assert not chain.tick()


def test_a_reply_already_late_is_not_held_for_its_wire_time_again(monkeypatch):
    chain = EmulatedChain(MockBus(ROBOT).devices)
    slept = []
    with PtyServer(chain, baud=1_000_000) as server:
        monkeypatch.setattr(time, "sleep", slept.append)
        reply = chain.handle(1, p2.PING, b"")
        delay_s = len(reply) * 10.0 / 1_000_000 + 2e-6 * chain.devices[1].get_named("return_delay_time")
        server._pace(reply, time.monotonic() - 1.0)  # heard a second ago (this side stalled)
        assert slept == []
        left = server._pace(reply, time.monotonic() + 1.0)  # heard just now, in effect
        assert len(slept) == 1 and 1.0 < slept[0] <= 1.0 + delay_s
        assert left >= time.monotonic()


def test_memory_is_locked_before_the_scheduling_class_changes(monkeypatch):
    calls = []
    monkeypatch.setattr(realtime, "_lock_memory", lambda: calls.append("lock") or None)
    monkeypatch.setattr(os, "sched_setscheduler", lambda *a: calls.append("fifo"))
    monkeypatch.setattr(os, "sched_setaffinity", lambda *a: calls.append("cpu"))
    grant = realtime.request_realtime(realtime.RealtimeRequest(priority=10, cpu=0, lock_memory=True))
    assert calls == ["lock", "cpu", "fifo"] and grant.memory_locked and grant.priority == 10


class _Asked(Exception):
    pass


def test_the_simulated_bus_builds_its_model_and_freezes_its_heap_before_it_asks_for_real_time(monkeypatch):
    events = []
    built = PhysicsChain.__init__

    def build(self, *args, **kwargs):
        built(self, *args, **kwargs)
        events.append("built")

    def asked(request):
        events.append(("asked", gc.get_freeze_count() > 0))
        raise _Asked  # enough: the order is what is checked, nothing is served

    monkeypatch.setattr(PhysicsChain, "__init__", build)
    monkeypatch.setattr(realtime, "request_realtime", asked)
    parser = argparse.ArgumentParser()
    service.add_arguments(parser)
    try:
        with pytest.raises(_Asked):
            service.serve(parser.parse_args(["--no-mlock"]))
    finally:
        gc.unfreeze()
    assert events == ["built", ("asked", True)]


def test_the_run_says_its_retry_budget_and_how_many_tries_failed_when_it_gives_up(served_chain, grown_controller):
    chain, port = served_chain
    lines = []

    def silence_in_the_loop(seconds):  # the runtime's own sleeps: the first one in the loop silences servo 3
        if any(line.startswith("bus reads:") for line in lines):
            chain.silent.add(3)
        time.sleep(seconds)

    report = drive(DynamixelBus(port, 1_000_000, ROBOT), ROBOT, grown_controller, duration_s=5, log=lines.append,
                   ramp_s=0.1, sleep=silence_in_the_loop, lost_after_s=0.2)
    budget = read_budget(grown_controller.tick_s, 0.2)
    assert budget in lines
    assert f"up to {TICK_ATTEMPTS} times" in budget and f"({READ_BUDGET:.0%})" in budget and "after 200 ms" in budget
    assert report.stop_reason.startswith("lost communication: servo 3")
    tries = int(report.stop_reason.split(": ")[-1].split()[0])
    assert tries >= 2 and "tries failed over" in report.stop_reason and report.stop_reason.endswith("ticks)")

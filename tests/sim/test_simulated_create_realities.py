"""Create realities against the byte-level simulated Create: sleep in Passive and the BRC wake
(through the serial line's RTS/DTR), the driver's keep-alive, and baud-rate detection."""

from __future__ import annotations

import pytest

from marknav.core.clock import ManualClock
from marknav.core.errors import InputError
from marknav.robot import oi
from marknav.robot.driver import AUTO_BAUDRATES, KEEPALIVE_PERIOD_S, CreateDriver
from marknav.robot.packets import Model, OIMode
from marknav.robot.transport import open_port
from marknav.sim.protocol_createsim import register, unregister
from marknav.sim.simulated_create import PASSIVE_SLEEP_S, SimulatedCreate


@pytest.fixture
def sim_url() -> object:
    made: list[str] = []

    def make(sim: SimulatedCreate) -> str:
        url = register(sim)
        made.append(url)
        return url

    yield make
    for url in made:
        unregister(url.split("://", 1)[1])


def _mode(port: object, model: Model = Model.CREATE2) -> bytes:
    port.write(oi.sensors(35, model=model))  # type: ignore[attr-defined]
    return port.read(1)  # type: ignore[attr-defined,no-any-return]


def test_passive_sleeps_after_five_minutes_and_a_brc_pulse_on_rts_wakes_it(sim_url) -> None:
    clock = ManualClock()
    sim = SimulatedCreate(clock=clock, brc_line="rts")
    port = open_port(sim_url(sim), baudrate=115200, timeout=0.01)
    port.write(oi.start())
    assert _mode(port) == bytes([OIMode.PASSIVE])
    sim.advance_to(PASSIVE_SLEEP_S - 1.0)
    assert not sim.asleep and _mode(port) == bytes([OIMode.PASSIVE])
    sim.advance_to(PASSIVE_SLEEP_S + 0.1)
    assert sim.asleep
    assert _mode(port) == b""  # asleep: every byte is ignored
    port.write(oi.start())
    assert sim.mode is OIMode.PASSIVE and sim.asleep
    # DTR is not wired to BRC on this cable: nothing happens
    port.dtr = True  # type: ignore[attr-defined]
    port.dtr = False  # type: ignore[attr-defined]
    assert sim.asleep
    port.rts = True  # type: ignore[attr-defined]  # asserted: BRC pulled low
    port.rts = False  # type: ignore[attr-defined]
    assert not sim.asleep and sim.mode is OIMode.OFF
    port.write(oi.start())
    assert _mode(port) == bytes([OIMode.PASSIVE])
    port.close()


def test_safe_mode_never_sleeps(sim_url) -> None:
    sim = SimulatedCreate(clock=ManualClock())
    port = open_port(sim_url(sim), baudrate=115200, timeout=0.01)
    port.write(oi.start() + oi.safe())
    sim.advance_to(2 * PASSIVE_SLEEP_S)
    assert not sim.asleep and _mode(port) == bytes([OIMode.SAFE])
    port.close()


def test_the_driver_wakes_a_sleeping_robot_and_keeps_it_awake_in_passive(sim_url) -> None:
    clock = ManualClock()
    sim = SimulatedCreate(clock=clock, brc_line="dtr")
    url = sim_url(sim)
    sim.write(oi.start())
    clock.advance(PASSIVE_SLEEP_S + 1.0)
    sim.sync()
    assert sim.asleep
    driver = CreateDriver(url, clock=clock, first_frame_timeout_s=None, settle_s=0.0,
                          reader_thread=False, brc_line="dtr", wake_pulse_s=0.0)
    with driver:
        assert sim.brc_pulses == 1 and not sim.asleep
        assert sim.mode is OIMode.SAFE and sim.streaming
        # the robot drops to Passive (here: told to); the driver keeps it awake past 5 minutes
        driver.set_mode(OIMode.PASSIVE)
        t = clock.now()
        while clock.now() < t + 2 * PASSIVE_SLEEP_S:
            clock.advance(0.5)
            sim.sync()
            driver.process_input()
        assert not sim.asleep
        expected = 2 * PASSIVE_SLEEP_S / KEEPALIVE_PERIOD_S
        assert expected - 1 <= sim.brc_pulses - 1 <= expected + 1
        assert driver.frames_received > 1000  # the stream kept coming


def test_without_a_brc_line_a_passive_robot_falls_asleep(sim_url) -> None:
    clock = ManualClock()
    sim = SimulatedCreate(clock=clock, brc_line=None)  # the cable wires BRC to nothing
    driver = CreateDriver(sim_url(sim), clock=clock, first_frame_timeout_s=None, settle_s=0.0,
                          reader_thread=False, wake_pulse_s=0.0)
    with driver:
        driver.set_mode(OIMode.PASSIVE)
        while clock.now() < PASSIVE_SLEEP_S + 1.0:
            clock.advance(0.5)
            sim.sync()
            driver.process_input()
        assert sim.asleep
        assert driver.safety_state == "fault"
        assert "no sensor frame" in (driver.fault_reason or "")


@pytest.mark.parametrize(("model", "robot_baud"), [("create2", 115200), ("create2", 57600),
                                                  ("create1", 57600)])
def test_baud_detection_finds_the_robots_rate(sim_url, model: str, robot_baud: int) -> None:
    sim = SimulatedCreate(model=model, clock=ManualClock())
    sim.baudrate = robot_baud  # its default, or what a Baud (129) command set
    driver = CreateDriver(sim_url(sim), model=model, baudrate="auto", clock=sim.clock,
                          first_frame_timeout_s=None, settle_s=0.0, reader_thread=False,
                          wake_pulse_s=0.0)
    with driver:
        assert driver.baudrate == robot_baud
        assert sim.mode is OIMode.SAFE and sim.streaming
        sim.step(0.05)
        assert driver.process_input() >= 3
        assert driver.parser.bad_frames == 0
        # on the slower line a Create 2 streams less (the budget of 86 bytes per 15 ms)
        assert driver.stream_frame_bytes <= 0.6 * robot_baud / 10 * 0.015


def test_a_robot_at_another_rate_is_a_dead_line_with_a_clear_message(sim_url) -> None:
    sim = SimulatedCreate(clock=ManualClock())
    sim.baudrate = 19200  # BRC pulsed three times after power-on
    url = sim_url(sim)
    driver = CreateDriver(url, baudrate="auto", clock=sim.clock, first_frame_timeout_s=None,
                          settle_s=0.0, reader_thread=False, wake_pulse_s=0.0)
    with pytest.raises(InputError) as info:
        driver.connect()
    assert "no answer at 115200 or 57600 baud: check power, cable and baud" in str(info.value)
    assert url in str(info.value)
    assert AUTO_BAUDRATES == (115200, 57600)
    assert sim.mode is OIMode.OFF and sim.ignored_bytes > 0  # it heard nothing it could read

import pytest

from transplanter.machine.eeprom import EepromImage, Pickup
from transplanter.machine.gcode import checksum, parse_line
from transplanter.machine.pgf import PGF, LinePhase, PGFConfig, build_program

CELL_X_MM = [-90, -45, 0, 45, 90]
ELBOW_DEG = ["80", "85", "90", "95", "100.5"]


def five_pickup_image() -> EepromImage:
    return EepromImage(
        pickups=tuple(
            Pickup((x / 1000, 0.175), (x / 1000, 0.215), float(e))
            for x, e in zip(CELL_X_MM, ELBOW_DEG, strict=True)
        ),
        drop_xy_m=(0.0, 0.140),
        drop_wrist_deg=12.5,
        z_up_m=0.100,
        z_low_m=0.032,
        s_low_m_s=0.040,
        s_high_m_s=0.150,
    )


def expected_lines(seedlings: int) -> list[tuple[int | None, str, str]]:
    lines = [
        (None, "home", "G28"),
        (None, "absolute", "G90"),
        (None, "start_elbow", "M280 P1 S12.5"),
        (None, "to_start", "G1 X0 Y140 Z100 S150"),
    ]
    for i in range(seedlings):
        c = i % 5
        x, e = CELL_X_MM[c], ELBOW_DEG[c]
        lines += [
            (i, "approach", f"G1 X{x} Y175 Z32 S150"),
            (i, "elbow", f"M280 P1 S{e}"),
            (i, "open", "M280 P0 S155"),
            (i, "open_wait", "G4 P200"),
            (i, "grip", f"G1 X{x} Y215 Z32 S40"),
            (i, "close", "M280 P0 S60"),
            (i, "close_wait", "G4 P250"),
            (i, "lift", f"G1 X{x} Y215 Z100 S40"),
            (i, "retract", f"G1 X{x} Y175 Z100 S150"),
            (i, "drop_elbow", "M280 P1 S12.5"),
            (i, "to_drop", "G1 X0 Y140 Z100 S150"),
            (i, "release", "M280 P0 S155"),
            (i, "release_wait", "G4 P200"),
        ]
        if c == 4 and i < seedlings - 1:
            lines.append((i, "index", "M710"))
    lines.append((None, "finish", "M400"))
    return lines


def run_with_instant_ok(pgf: PGF, dt: float = 0.1) -> None:
    now = 0.0
    replies: list[str] = []
    for _ in range(10_000):
        sent = pgf.poll(now, replies)
        assert len(sent) <= 1
        replies = ["ok"] * len(sent)
        now += dt
        if pgf.done:
            return
    raise AssertionError("PGF did not finish")


def test_exact_sequence_five_pickups_seven_seedlings_unframed():
    pgf = PGF(five_pickup_image(), PGFConfig(seedlings=7, line_numbers=False))
    run_with_instant_ok(pgf)
    got = [(s.seedling, s.phase, s.text) for s in pgf.sent]
    assert got == expected_lines(7)
    # the conveyor indexes exactly once: after the 5th seedling (pickup 5 of the row)
    assert [(s.seedling, s.text) for s in pgf.sent if s.phase is LinePhase.INDEX] == [(4, "M710")]
    assert all(s.reply == "ok" and s.t_reply > s.t_sent for s in pgf.sent)
    assert pgf.done and pgf.fault is None and pgf.current is None


def test_framed_lines_are_numbered_and_checksummed():
    pgf = PGF(five_pickup_image(), PGFConfig(seedlings=7))
    run_with_instant_ok(pgf)
    expected = expected_lines(7)
    assert len(pgf.sent) == len(expected)
    for number, (sent, (_, _, text)) in enumerate(zip(pgf.sent, expected, strict=True), 1):
        framed = f"N{number} {text}"
        assert sent.text == f"{framed}*{checksum(framed)}"
        assert parse_line(sent.text, expected_line_number=number, require_checksum=True)


def test_no_index_when_disabled_or_last_seedling():
    lines = build_program(five_pickup_image(), PGFConfig(seedlings=5, line_numbers=False))
    assert not any(line.phase is LinePhase.INDEX for line in lines)
    lines = build_program(five_pickup_image(), PGFConfig(seedlings=12, index_conveyor=False))
    assert not any(line.phase is LinePhase.INDEX for line in lines)
    lines = build_program(five_pickup_image(), PGFConfig(seedlings=11, line_numbers=False))
    assert [line.seedling for line in lines if line.phase is LinePhase.INDEX] == [4, 9]


def test_nothing_sent_while_a_line_is_outstanding():
    pgf = PGF(five_pickup_image(), PGFConfig(seedlings=1, line_numbers=False))
    assert pgf.poll(0.0, []) == ["G28"]
    assert pgf.current.text == "G28" and pgf.current.t_reply is None
    for t in (0.1, 0.2, 5.0):
        assert pgf.poll(t, []) == []
    assert pgf.poll(5.1, ["X:0.000 Y:0.000"]) == []  # an info line is no handshake
    assert pgf.info == [(5.1, "X:0.000 Y:0.000")]
    assert pgf.poll(6.0, ["ok"]) == ["G90"]
    assert pgf.sent[0].t_sent == 0.0 and pgf.sent[0].t_reply == 6.0
    assert pgf.sent[1].t_sent == 6.0
    assert not pgf.done


def test_error_reply_faults_and_stops():
    pgf = PGF(five_pickup_image(), PGFConfig(seedlings=2, line_numbers=False))
    pgf.poll(0.0, [])
    pgf.poll(1.0, ["ok"])
    assert pgf.poll(2.0, ["ok"]) == ["M280 P1 S12.5"]
    assert pgf.poll(2.5, ["ok"]) == ["G1 X0 Y140 Z100 S150"]
    assert pgf.poll(2.7, ["ok"]) == ["G1 X-90 Y175 Z32 S150"]
    assert pgf.poll(3.0, ["error:33 target position not reachable: x"]) == []
    assert "not reachable" in pgf.fault and "approach" in pgf.fault
    assert pgf.sent[-1].reply.startswith("error:33") and pgf.sent[-1].t_reply == 3.0
    assert pgf.poll(4.0, ["ok"]) == [] and pgf.poll(5.0, []) == []
    assert len(pgf.sent) == 5 and not pgf.done and pgf.current is None


def test_unexpected_ok_faults():
    pgf = PGF(five_pickup_image(), PGFConfig(seedlings=1))
    assert pgf.poll(0.0, ["ok"]) == []
    assert "unexpected" in pgf.fault


def test_two_oks_for_one_line_fault():
    pgf = PGF(five_pickup_image(), PGFConfig(seedlings=1))
    pgf.poll(0.0, [])
    assert pgf.poll(1.0, ["ok", "ok"]) == []
    assert "unexpected" in pgf.fault


@pytest.mark.parametrize(
    "kwargs",
    [
        {"gripper_servo": 2},
        {"wrist_servo": 0},
        {"gripper_open_deg": 190.0},
        {"close_dwell_s": -0.1},
        {"seedlings": 0},
        {"seedlings": 2.5},
    ],
)
def test_config_validation(kwargs):
    with pytest.raises(ValueError):
        PGFConfig(**kwargs)


def test_line_phases_are_members_that_still_compare_as_strings():
    program = build_program(five_pickup_image(), PGFConfig(seedlings=1, line_numbers=False))
    assert all(isinstance(line.phase, LinePhase) for line in program)
    phases = [line.phase for line in program]
    assert phases[:4] == [
        LinePhase.HOME,
        LinePhase.ABSOLUTE,
        LinePhase.START_ELBOW,
        LinePhase.TO_START,
    ]
    assert phases[-1] is LinePhase.FINISH
    # StrEnum: code comparing with the former bare strings keeps working
    assert phases[4] == "approach" and f"{phases[4]}: x" == "approach: x"
    assert [p for p in phases if p in ("close", "lift", "to_drop")] == [
        LinePhase.CLOSE,
        LinePhase.LIFT,
        LinePhase.TO_DROP,
    ]


def test_rehome_every_n_cycles_opens_those_cycles():
    """Recovery: G28 and back to the drop point open cycles 3, 6, ... (every 3rd after the
    first three); the default, as the paper's open-loop machine, never re-homes."""
    image = five_pickup_image()
    plain = build_program(image, PGFConfig(seedlings=7, line_numbers=False))
    assert not any(line.phase is LinePhase.REHOME for line in plain)
    lines = build_program(image, PGFConfig(seedlings=7, line_numbers=False, rehome_every_cycles=3))
    rehomes = [line for line in lines if line.phase is LinePhase.REHOME]
    assert [(line.seedling, line.text) for line in rehomes] == [(3, "G28"), (6, "G28")]
    for seedling in (3, 6):
        first = [line for line in lines if line.seedling == seedling][:3]
        assert [line.phase for line in first] == [
            LinePhase.REHOME, LinePhase.REHOME_TO_START, LinePhase.APPROACH,
        ]  # fmt: skip
        assert first[1].text == next(ln.text for ln in lines if ln.phase is LinePhase.TO_START)
    assert len(lines) == len(plain) + 4
    with pytest.raises(ValueError, match="rehome_every_cycles"):
        PGFConfig(rehome_every_cycles=-1)


def _to_grip(pgf: PGF) -> float:
    """Answer ok until the first seedling's grip line is outstanding; return the time."""
    now, replies = 0.0, []
    while True:
        pgf.poll(now, replies)
        if pgf.current.phase == LinePhase.GRIP:
            return now
        replies, now = ["ok"], now + 0.1


STALL_REPLY = "error:67 motor 2 stalled at t=3.575 s: motion stopped, position lost; home with G28"


def test_a_stall_without_recovery_faults_like_any_refused_line():
    pgf = PGF(five_pickup_image(), PGFConfig(seedlings=2, line_numbers=False))
    now = _to_grip(pgf)
    assert pgf.poll(now + 0.1, [STALL_REPLY]) == []
    assert "error:67" in pgf.fault and "grip" in pgf.fault and pgf.stalls == []


@pytest.mark.parametrize(
    ("phase", "resume", "resume_text"),
    [
        ("grip", "approach", "G1 X-90 Y175 Z32 S150"),  # gripper open: retry the seedling
        ("lift", "drop_elbow", "M280 P1 S12.5"),  # pot maybe in the jaws: carry it to the tube
        ("release_wait", "release_wait", "G4 P200"),  # after the release: the line again
    ],
)
def test_a_stall_with_recovery_settles_rehomes_and_resumes(phase, resume, resume_text):
    config = PGFConfig(seedlings=2, line_numbers=False, stall_recovery=True, stall_settle_s=0.4)
    pgf = PGF(five_pickup_image(), config)
    now, replies = 0.0, []
    while True:
        pgf.poll(now, replies)
        if pgf.current.phase == phase and pgf.current.seedling == 0:
            break
        replies, now = ["ok"], now + 0.1
    assert pgf.poll(now + 0.1, [STALL_REPLY]) == ["G4 P400"]
    assert pgf.fault is None and pgf.stalls[0][1].phase == phase
    assert pgf.poll(now + 0.5, ["ok"]) == ["G28"]
    assert pgf.poll(now + 3.0, ["ok"]) == ["G1 X0 Y140 Z100 S150"]
    assert pgf.poll(now + 5.0, ["ok"]) == [resume_text]
    assert [s.phase for s in pgf.sent[-4:]] == [
        "stall_settle",
        "stall_rehome",
        "stall_to_start",
        resume,
    ]
    assert all(s.seedling == 0 for s in pgf.sent[-4:])
    for _ in range(200):  # ok to everything from here
        if pgf.done:
            break
        now += 0.1
        pgf.poll(now + 6.0, ["ok"])
    assert pgf.done and pgf.sent[-1].phase == "finish"
    # after the detour the program goes on to the end, each line once more at most
    assert sum(s.phase == "to_drop" for s in pgf.sent) == 2


def test_stall_recovery_gives_a_seedling_up_after_the_retries_and_numbers_lines_as_sent():
    """Seedling 4 (the row's last) keeps stalling at its grip: after 2 recoveries the third
    stall gives it up; the PGF re-homes, still indexes the conveyor and goes on with
    seedling 5. Line numbers follow the lines as sent."""
    config = PGFConfig(seedlings=6, stall_recovery=True, stall_retries=2)
    pgf = PGF(five_pickup_image(), config)
    now, replies = 0.0, []
    while True:
        pgf.poll(now, replies)
        if pgf.current.phase == LinePhase.GRIP and pgf.current.seedling == 4:
            break
        replies, now = ["ok"], now + 0.1
    for attempt in range(3):
        sent = pgf.poll(now + 0.1, [STALL_REPLY])
        assert parse_line(sent[0]).command == "G4", attempt
        for _ in range(3 if attempt == 2 else 7):  # settle, G28, to start, (approach ... wait)
            sent = pgf.poll(now + 0.2, ["ok"])
            now += 0.2
        if attempt < 2:
            assert pgf.current.phase == "grip" and pgf.current.seedling == 4
    assert pgf.abandoned == [4] and len(pgf.stalls) == 3 and pgf.fault is None
    assert [(s.seedling, s.phase) for s in pgf.sent[-2:]] == [(4, "stall_to_start"), (4, "index")]
    pgf.poll(now + 0.1, ["ok"])
    assert (pgf.current.seedling, pgf.current.phase) == (5, "approach")
    numbers = [parse_line(s.text).line_number for s in pgf.sent]
    assert numbers == list(range(1, len(pgf.sent) + 1))  # the detour shifts later numbers


def test_a_stall_outside_a_cycle_beyond_the_retries_faults():
    pgf = PGF(five_pickup_image(), PGFConfig(seedlings=1, stall_recovery=True, stall_retries=1))
    pgf.poll(0.0, [])
    assert pgf.current.phase == "home"
    assert parse_line(pgf.poll(0.1, [STALL_REPLY])[0]).command == "G28"  # homing again
    assert pgf.poll(0.2, [STALL_REPLY]) == []
    assert "error:67" in pgf.fault and pgf.abandoned == []
    assert pgf.fault_kind == "motor_stalled"


def test_a_seedling_given_up_that_stalls_again_stops_the_pgf():
    """A jam: the seedling is given up after its retries, and its re-home stalls once more:
    the machine cannot even home, so the PGF stops instead of re-homing for ever."""
    config = PGFConfig(seedlings=2, line_numbers=False, stall_recovery=True, stall_retries=1)
    pgf = PGF(five_pickup_image(), config)
    now = _to_grip(pgf)
    assert pgf.poll(now + 0.1, [STALL_REPLY]) == ["G4 P300"]  # recovery 1
    assert pgf.poll(now + 0.5, ["ok"]) == ["G28"]
    assert pgf.poll(now + 0.6, [STALL_REPLY]) == ["G4 P300"]  # the re-home stalls: given up
    assert pgf.abandoned == [0] and pgf.fault is None
    assert pgf.poll(now + 1.0, ["ok"]) == ["G28"]
    assert pgf.poll(now + 1.1, [STALL_REPLY]) == []
    assert pgf.fault == f"SGF refused 'G28' (stall_rehome): {STALL_REPLY}"
    assert pgf.fault_kind == "motor_stalled"


def test_reply_timeout_restarts_on_any_line_and_stops_the_pgf():
    pgf = PGF(five_pickup_image(), PGFConfig(seedlings=1, reply_timeout_s=10.0))
    assert pgf.next_event_time() is None  # nothing outstanding yet
    assert pgf.poll(1.0, []) == ["N1 G28*18"]
    assert pgf.next_event_time() == 11.0
    assert pgf.poll(9.0, ["echo:busy"]) == []  # a line that is not the reply: still alive
    assert pgf.next_event_time() == 19.0 and pgf.fault is None
    assert pgf.poll(18.9, []) == [] and pgf.fault is None
    assert pgf.poll(19.0, []) == []
    assert pgf.fault == (
        "bus timeout: no reply to line 1 'N1 G28*18' (home) within 10 s; check the serial "
        "cable and that the SGF is powered and running"
    )
    assert pgf.fault_kind == "bus_timeout" and pgf.next_event_time() is None
    assert pgf.poll(20.0, ["ok"]) == [] and len(pgf.sent) == 1  # nothing more is sent


@pytest.mark.parametrize(
    ("reply", "kind"),
    [
        ("error:33 target position not reachable", "line_refused"),
        ("error:68 homing failed: limit switch 3 (Z up) still closed", "switch_stuck_closed"),
        ("error:69 homing failed: limit switch 1 (arm 1 home) not found", "switch_not_found"),
        ("error:70 limit switch 4 (Z down) reads closed", "switch_stuck_closed"),
        (STALL_REPLY, "motor_stalled"),
    ],
)
def test_fault_kind_comes_from_the_reply_code(reply, kind):
    pgf = PGF(five_pickup_image(), PGFConfig(seedlings=1))
    pgf.poll(0.0, [])
    pgf.poll(0.1, [reply])
    assert pgf.fault_kind == kind and reply in pgf.fault


def test_an_unexpected_reply_is_a_protocol_fault():
    pgf = PGF(five_pickup_image(), PGFConfig(seedlings=1))
    pgf.poll(0.0, ["ok"])
    assert pgf.fault_kind == "protocol" and pgf.fault.startswith("unexpected 'ok'")
    with pytest.raises(ValueError, match="reply_timeout_s"):
        PGFConfig(reply_timeout_s=0.0)

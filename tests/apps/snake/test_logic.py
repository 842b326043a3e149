"""The Snake game, the region -> direction mapping and the one-press-one-command detector,
without a sensor (UI-free logic)."""

from __future__ import annotations

from types import SimpleNamespace

import pytest
from spectratac.apps.snake.control import CommandDetector
from spectratac.apps.snake.controller import SnakeController
from spectratac.apps.snake.game import SnakeGame
from spectratac.apps.snake.mapping import DirectionMap, MappingError
from spectratac.errors import SpectraTacError
from spectratac.hardware.generated import vocabulary as vocab


def est(normal: float, region: int, *, ood: bool = False, invalid: bool = False):
    return SimpleNamespace(force=[0.0, 0.0, -normal], region=region, ood=ood, invalid=invalid)


def feed(det: CommandDetector, trace: list[tuple[float, int]], **flags) -> list:
    out = [det.feed(est(f, r, **flags), i * 0.05) for i, (f, r) in enumerate(trace)]
    return [(c.direction, c.region) for c in out if c is not None]


# ---------------------------------------------------------------- mapping
def test_default_mapping_follows_the_paper_centre_neutral() -> None:
    m = DirectionMap()
    assert [m.direction(r) for r in vocab.REGIONS] == [
        None, "up", None, "left", None, "right", None, "down", None
    ]  # fmt: skip
    keypad = DirectionMap.parse("keypad")
    assert [keypad.direction(r) for r in (1, 3, 7, 9, 5)] == ["up", "up", "down", "down", None]
    custom = DirectionMap.parse("keypad,3=right,2=none")
    assert custom.direction(3) == "right" and custom.direction(2) is None
    assert custom.as_dict()["5"] == "none"


@pytest.mark.parametrize("text", ["0=up", "10=up", "1=north", "upward", "1:up"])
def test_bad_mappings_say_what_to_give(text: str) -> None:
    with pytest.raises(MappingError, match=r"region|direction"):
        DirectionMap.parse(text)


# ---------------------------------------------------------------- detector
def test_one_press_gives_one_command_despite_jitter_around_the_threshold() -> None:
    det = CommandDetector(confirm=2, rearm=2)
    # rises, trembles across 1.0 N (but never below the 0.7 N release), slides to 3
    press = [(0.3, 2), (1.2, 2), (1.3, 2), (0.95, 2), (1.1, 2), (0.8, 3), (1.4, 3), (1.5, 3)]
    release = [(0.4, 2), (0.2, 2)]
    assert feed(det, press + release + press) == [("up", 2), ("up", 2)]


def test_no_command_at_or_below_the_threshold() -> None:
    det = CommandDetector(threshold_n=1.0)
    assert feed(det, [(1.0, 2)] * 20 + [(0.99, 6)] * 20) == []
    assert not det.pressed


def test_the_region_must_hold_before_a_press_is_decided() -> None:
    det = CommandDetector(confirm=3)
    # misread as 3 for one sample on the way up: the press is decided on 2 once it holds
    assert feed(det, [(1.5, 3), (1.6, 2), (1.7, 2), (1.8, 2), (1.8, 2)]) == [("up", 2)]


def test_the_region_is_decided_on_the_steady_part_not_the_rise() -> None:
    """Issue 22 item 3: a rise misread as "left" for two samples no longer fires "left"."""
    det = CommandDetector(confirm=2)
    rise = [(1.2, 4), (1.8, 4), (2.5, 2), (2.9, 2), (3.0, 2), (3.0, 2)]
    assert feed(det, rise + [(0.2, 2)] * 3) == [("up", 2)]


def test_a_press_that_never_holds_still_is_decided_near_its_peak() -> None:
    det = CommandDetector(confirm=2)
    spike = [(1.1, 4), (1.6, 8), (2.4, 8), (3.2, 8), (2.2, 8), (0.5, 8), (0.2, 8)]
    assert feed(det, spike) == [("down", 8)]  # decided as it fell below 80 % of 3.2 N
    brief = [(1.4, 6), (2.0, 6), (0.3, 6), (0.2, 6)]
    assert feed(CommandDetector(confirm=3), brief) == [("right", 6)]  # decided at release


def test_a_flickering_ood_flag_never_fires_a_steady_press_twice() -> None:
    """Issue 22 item 3: OOD estimates inside a press are unknown, not a release."""
    det = CommandDetector()
    out = []
    for i in range(40):  # a 2 s steady press on "right"; the flag flickers on 2 of every 5
        e = est(2.5, 6, ood=i % 5 in (2, 3))
        c = det.feed(e, i * 0.05)
        out += [c.direction] if c else []
    assert out == ["right"]
    assert det.pressed  # still the same press


def test_centre_presses_are_decided_neutral_and_unusable_estimates_are_no_press() -> None:
    det = CommandDetector()
    assert feed(det, [(2.0, 5)] * 5) == [(None, 5)]
    det.reset()
    assert feed(det, [(3.0, 2)] * 5, ood=True) == []
    assert feed(det, [(3.0, 2)] * 5, invalid=True) == []
    assert feed(CommandDetector(accept_ood=True), [(3.0, 2)] * 5, ood=True) == [("up", 2)]


def test_the_threshold_is_configurable() -> None:
    assert feed(CommandDetector(threshold_n=2.0), [(1.8, 8)] * 5) == []
    assert feed(CommandDetector(threshold_n=1.5), [(1.8, 8)] * 5) == [("down", 8)]
    with pytest.raises(SpectraTacError, match="hysteresis"):
        CommandDetector(threshold_n=1.0, hysteresis_n=1.5)


# ---------------------------------------------------------------- game
def test_snake_moves_turns_eats_and_dies_on_the_wall() -> None:
    g = SnakeGame(width=8, height=5, seed=0)
    assert g.head == (4, 2) and g.body == [(4, 2), (3, 2), (2, 2)]
    g.food = (5, 2)
    g.step()
    assert g.head == (5, 2) and g.score == 1 and len(g.body) == 4 and g.food not in g.body
    g.turn("left")  # straight back: ignored
    g.turn("up")
    g.step()
    g.step()
    assert g.head == (5, 0) and g.alive
    g.step()
    assert not g.alive and g.outcome().steps == 3
    g.step()
    assert g.outcome().head == (5, 0)


def test_snake_dies_on_itself_and_food_is_seeded() -> None:
    g = SnakeGame(width=10, height=6, length=5, seed=3)
    for d in ("up", "left", "down"):
        g.turn(d)
        g.step()
    assert not g.alive
    assert SnakeGame(seed=7).food == SnakeGame(seed=7).food
    with pytest.raises(SpectraTacError, match="grid"):
        SnakeGame(width=3)


# ---------------------------------------------------------------- controller
def test_the_game_waits_for_the_first_command_then_ticks_on_the_sensor_clock() -> None:
    ctl = SnakeController(tick_s=0.5)
    for i in range(40):  # 2 s of no contact
        ctl.feed(est(0.0, 5), i * 0.05)
    assert not ctl.started and ctl.game.steps == 0
    trace = [(2.0, 4)] * 6 + [(0.0, 4)] * 34  # a press on "left" at 2.0 s, then 1.7 s idle
    for i, (f, r) in enumerate(trace, start=40):
        ctl.feed(est(f, r), i * 0.05)
    # decided at 2.05 s; moves at 2.5, 3.0, 3.5 (right is the start heading: left is a U-turn)
    assert [c.direction for c in ctl.history] == ["left"] and ctl.game.steps == 3
    assert ctl.game.direction == "right"
    state = ctl.state()
    assert state["started"] and state["commands"][0]["region"] == 4

"""`simulate` runs FMI 3.0 Model Exchange FMUs with periodic input clocks as the standard asks
the importer to (FMI 3.0.2 section 2.2.8): each tick of a time-based input clock is a time
event at t_start + shift + k interval, where the clock is set active with fmi3SetClock in
Event Mode; the variables it clocks are read only while it is active (or in Initialization
Mode) and hold their value between ticks. Output and local clocks are inquired with fmi3GetClock
in Event Mode and the variables they clock read while they are active. A clock of no kind the
standard defines is refused with the clause.

The fixture (tests/fixtures/toy-fmus/sampler.c) counts the ticks of a clock with interval
0.25 s and shift 0.1 s into its clocked output n and integrates der(x) = n; it announces no
time event of its own and fails a read of n while its clock is inactive. Reference values are
the closed forms n(t) = #{k : t_k <= t}, x(t) = sum over t_k <= t of (t - t_k).

(FMPy's `simulate_fmu` never calls fmi3SetClock in Model Exchange: on an FMU like this it
reads n outside its clock, which the standard does not allow, and never counts a tick.)
"""
import sys
import zipfile

import numpy as np
import pytest

from conftest import read_csv_floats as read_csv
from conftest import run_cli as run

pytestmark = pytest.mark.skipif(sys.platform != "linux",
                                reason="the fixtures are built for linux64")

SHIFT, INTERVAL, STOP = 0.1, 0.25, 2.0
TICKS = SHIFT + INTERVAL * np.arange(int((STOP - SHIFT) / INTERVAL) + 1)


def closed_form(t, after=True):
    """n and x at t: right after the ticks at t (`after`), or right before them."""
    done = TICKS <= t if after else TICKS < t - 1e-12
    return done.sum(), np.sum(t - TICKS[done])


def test_a_periodic_input_clock_ticks_at_its_shift_and_interval(toy, tmp_path):
    out = tmp_path / "o.csv"
    r = run("simulate", toy("Sampler", 3), "--out", out)
    assert r.returncode == 0, r.stderr
    header, rows = read_csv(out)
    assert header == ["time", "x", "n"]
    t, x, n = rows.T
    assert t[0] == 0.0 and t[-1] == pytest.approx(STOP)
    # every tick is an event: a row before it and one after it, at the tick's time
    for tk in TICKS:
        at = np.flatnonzero(np.abs(t - tk) <= 1e-12 * max(1.0, tk))
        assert len(at) == 2, (tk, t[max(0, at[0] - 2) if len(at) else 0:][:6])
        assert (n[at[0]], n[at[1]]) == (closed_form(tk, False)[0], closed_form(tk)[0])
    for k in range(len(t)):
        # the last row at a time is the value after its events
        last = k + 1 == len(t) or t[k + 1] != t[k]
        want_n, want_x = closed_form(t[k], after=last)
        assert n[k] == want_n, (t[k], n[k], want_n)
        assert x[k] == pytest.approx(want_x, abs=1e-9), (t[k], x[k], want_x)
    # before the first tick n is the value of Initialization Mode (an <InitialUnknown>)
    assert n[0] == 0 and n[t < SHIFT].max() == 0


def with_clock(src, dst, old, new):
    """Copy of the FMU `src` with `old` replaced by `new` in its description."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "modelDescription.xml":
                md = data.decode()
                assert old in md
                data = md.replace(old, new).encode()
            zout.writestr(item, data)
    return dst


CLOCK = ('<Clock name="tick" valueReference="5" causality="input" variability="discrete" '
         'intervalVariability="constant" intervalDecimal="0.25" shiftDecimal="0.1"/>')


def test_a_clock_of_no_kind_the_standard_defines_is_refused_citing_the_clause(toy, tmp_path):
    # an output clock must be triggered (FMI 3.0.2 section 2.2.8.2)
    clock = ('<Clock name="tick" valueReference="5" causality="output" variability="discrete" '
             'intervalVariability="constant"/>')
    fmu = with_clock(toy("Sampler", 3), tmp_path / "Sampler.fmu", CLOCK, clock)
    out = tmp_path / "o.csv"
    r = run("simulate", fmu, "--out", out)
    assert r.returncode == 2, r.stderr
    assert "clock 'tick'" in r.stderr and "is of no kind the standard defines" in r.stderr
    assert "FMI 3.0.2 section 2.2.8.2" in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and not out.exists()


# Ticker (tests/fixtures/toy-fmus/ticker.c): the input clock `tick` (t_k = 0.1 + 0.25 k) counted
# into n, the output clock `even` the FMU activates at the ticks that make n even, counted into
# m, the local clock `loc` active at every tick, clocking the local l = n.
TICKER_TICKS = SHIFT + INTERVAL * np.arange(8)  # 0.1 ... 1.85, all before the stop time 2


def ticks_done(ticks, t, after=True):
    """How many of `ticks` happened by t: including those at t (`after`), or not."""
    return int(np.sum(ticks <= t + 1e-12)) if after else int(np.sum(ticks < t - 1e-12))


def last_at_its_time(t):
    """Per row: whether it is the last row at its time (the value after the events there)."""
    return np.append(t[1:] != t[:-1], True)


def before_events_but_at_start(t):
    """Per row of a Co-Simulation run: the row at an output point holds the values before the
    events there (recorded as the step reached it, as FMPy records), but for the first row,
    recorded after the Event Mode that follows initialization."""
    return t == t[0]


def check_ticker(t, cols, after=None):
    """n, m, l and x of Ticker against the closed forms at each row; `after`: per row, whether
    it holds the values after the events at its time (default: the last row at its time)."""
    last = last_at_its_time(t) if after is None else after
    for k in range(len(t)):
        n = ticks_done(TICKER_TICKS, t[k], after=last[k])
        assert cols["n"][k] == n, (t[k], cols["n"][k], n)
        if "m" in cols:
            assert cols["m"][k] == n // 2, (t[k], cols["m"][k], n)
        done = TICKER_TICKS[TICKER_TICKS <= t[k] + 1e-12] if last[k] else TICKER_TICKS[:n]
        assert cols["x"][k] == pytest.approx(np.sum(t[k] - done), abs=1e-9), t[k]
        if "l" in cols:
            # a local clocked variable that is no <InitialUnknown>: none before the first tick
            assert (np.isnan(cols["l"][k]) if n == 0 else cols["l"][k] == n), (t[k], n)


def test_output_and_local_clocks_are_inquired_in_model_exchange(toy, tmp_path):
    out = tmp_path / "o.csv"
    r = run("simulate", toy("Ticker", 3), "--interface", "me", "--outputs", "x,n,m,l",
            "--out", out)
    assert r.returncode == 0, r.stderr
    header, rows = read_csv(out)
    assert header == ["time", "x", "n", "m", "l"]
    t = rows[:, 0]
    check_ticker(t, dict(zip(header, rows.T)))
    # the output clock ticked at every second tick: m reached 4 by the eighth tick
    assert rows[-1, 3] == 4 and t[-1] == pytest.approx(STOP)


def test_an_output_clock_is_no_recorded_output(toy, tmp_path):
    # a Clock has no value between its ticks: the default outputs are its clocked variables
    out = tmp_path / "o.csv"
    r = run("simulate", toy("Ticker", 3), "--interface", "me", "--out", out)
    assert r.returncode == 0, r.stderr
    assert read_csv(out)[0] == ["time", "x", "n", "m", "c", "h", "alarms", "t_alarm",
                                    "y", "u_at"]
    r = run("simulate", toy("Ticker", 3), "--interface", "me", "--outputs", "even",
            "--out", tmp_path / "e.csv")
    assert r.returncode == 2 and "'even' is a Clock" in r.stderr, r.stderr


def announced_ticks(first, interval_after, stop=STOP):
    """Ticks of an aperiodic clock: the first at `first`, the one after the j-th tick (j = 1,
    2, ...) `interval_after(j)` later (its interval relative to the Event Mode of that tick)."""
    ticks = [first]
    while ticks[-1] + interval_after(len(ticks)) < stop and len(ticks) < 100:
        ticks.append(ticks[-1] + interval_after(len(ticks)))
    return np.array(ticks)


# cd (countdown): 0.3 s from the start, then 0.2 (j - 1) s after its j-th tick (0 after the
# first: it ticks twice at 0.3, in one Event Mode); ch (changing): 0.15 s,
# then 0.2 + 0.1 j s after its j-th tick (FMI 3.0.2 section 2.2.8.2: t_0 = t_start +
# T_interval,0, t_i = t_event + T_interval,i for countdown, t_(i-1) + T_interval,i for changing)
COUNTDOWN_TICKS = announced_ticks(0.3, lambda j: 0.2 * (j - 1))  # 0.3, 0.3, 0.5, 0.9, 1.5
CHANGING_TICKS = announced_ticks(0.15, lambda j: 0.2 + 0.1 * j)  # 0.15, 0.45, 0.85, 1.35, 1.95


def check_aperiodic(t, cols, after=None):
    """c and h of Ticker against the ticks its aperiodic clocks announce (`after`: as in
    check_ticker)."""
    last = last_at_its_time(t) if after is None else after
    for k in range(len(t)):
        for name, ticks in (("c", COUNTDOWN_TICKS), ("h", CHANGING_TICKS)):
            want = ticks_done(ticks, t[k], after=last[k])
            assert cols[name][k] == want, (name, t[k], cols[name][k], want)


def test_aperiodic_input_clocks_tick_where_the_fmu_announces(toy, tmp_path):
    out = tmp_path / "o.csv"
    r = run("simulate", toy("Ticker", 3), "--interface", "me", "--out", out)
    assert r.returncode == 0, r.stderr
    header, rows = read_csv(out)
    assert header == ["time", "x", "n", "m", "c", "h", "alarms", "t_alarm",
                                    "y", "u_at"]
    t = rows[:, 0]
    cols = dict(zip(header, rows.T))
    check_ticker(t, cols)
    check_aperiodic(t, cols)
    # each tick is an event: a row before it and one after it at its time
    for tk in np.concatenate([COUNTDOWN_TICKS, CHANGING_TICKS]):
        assert np.sum(np.abs(t - tk) <= 1e-9) == 2, tk
    assert (cols["c"][-1], cols["h"][-1]) == (5, 5)


# Co-Simulation: Ticker declares hasEventMode; its clocks are driven in Event Mode at their
# ticks, each communication step ending at the next tick (FMI 3.0.2 sections 2.3.1, 4.2).
def test_clocks_tick_in_co_simulation_with_event_mode(toy, tmp_path):
    out = tmp_path / "o.csv"
    r = run("simulate", toy("Ticker", 3), "--interface", "cs", "--outputs", "x,n,m,l,c,h",
            "--out", out)
    assert r.returncode == 0, r.stderr
    header, rows = read_csv(out)
    assert header == ["time", "x", "n", "m", "l", "c", "h"]
    t = rows[:, 0]
    # rows at the output points (DefaultExperiment stepSize 0.05), before the events there
    assert np.allclose(t, 0.05 * np.arange(41), atol=1e-12, rtol=0)
    cols = dict(zip(header, rows.T))
    check_ticker(t, cols, before_events_but_at_start(t))
    check_aperiodic(t, cols, before_events_but_at_start(t))
    assert (cols["n"][-1], cols["m"][-1], cols["c"][-1], cols["h"][-1]) == (8, 4, 5, 5)


def test_clocks_without_event_mode_run_with_a_note(toy, tmp_path):
    # hasEventMode must be true for an FMU with clocks (FMI 3.0.2 section 4.4); without it the
    # run uses no Event Mode, the FMU ignores its clocks, and the run says so
    fmu = with_clock(toy("Ticker", 3), tmp_path / "Ticker.fmu", 'hasEventMode="true" ', "")
    out = tmp_path / "o.csv"
    r = run("simulate", fmu, "--interface", "cs", "--outputs", "x,n", "--out", out)
    assert r.returncode == 0, r.stderr
    assert "note: the FMU has clocks but no hasEventMode" in r.stderr, r.stderr
    header, rows = read_csv(out)
    # no tick: n keeps its Initialization Mode value, x its start
    assert header == ["time", "x", "n"] and (rows[:, 1:] == 0).all()


def test_clocks_of_a_binary_without_fmi3EnterStepMode_run_with_a_note_naming_it(toy, tmp_path):
    # every function of fmi3Functions.h must be exported (FMI 3.0.2 section 2.5); a binary
    # without fmi3EnterStepMode cannot leave Event Mode, so the run uses none and says why
    out = tmp_path / "o.csv"
    r = run("simulate", toy("TickerNoStepMode", 3), "--interface", "cs", "--outputs", "x,n",
            "--out", out)
    assert r.returncode == 0, r.stderr
    assert "does not export fmi3EnterStepMode" in r.stderr, r.stderr
    header, rows = read_csv(out)
    assert header == ["time", "x", "n"] and (rows[:, 1:] == 0).all()


def x_closed(t):
    """Ticker's x at t: the integral of the tick count."""
    return np.sum(np.maximum(t - TICKER_TICKS, 0.0))


def crossings(stop=STOP):
    """The times x reaches 1, 2, 3, ...: on each piece between ticks x is linear with slope
    the count so far."""
    edges = np.append(TICKER_TICKS, stop)
    found = []
    for j in range(len(TICKER_TICKS)):
        a, b, slope = edges[j], edges[j + 1], j + 1
        xa = x_closed(a)
        for level in range(int(np.floor(xa)) + 1, int(np.floor(x_closed(b))) + 1):
            found.append(a + (level - xa) / slope)
    return np.array(found)


def check_alarms(t, cols, handled_at, after=None):
    """alarms and t_alarm at each row, the k-th alarm handled at handled_at[k]; rows near a
    crossing are left out (before or after it is a matter of rounding there); `after`: as in
    check_ticker."""
    near = crossings()
    last = last_at_its_time(t) if after is None else after
    for k in range(len(t)):
        if np.min(np.abs(near - t[k])) < 1e-6:
            continue
        done = handled_at[handled_at <= t[k] + (1e-12 if last[k] else -1e-12)]
        assert cols["alarms"][k] == len(done), (t[k], cols["alarms"][k], done)
        want = done[-1] if len(done) else -1
        assert cols["t_alarm"][k] == pytest.approx(want, abs=1e-8), (t[k], want)


@pytest.mark.parametrize("interface", ["me", "cs"])
def test_an_event_inside_a_step_is_handled_where_the_fmu_met_it(interface, toy, tmp_path):
    # Model Exchange: a state event located by the host; Co-Simulation: fmi3DoStep returns early
    # with eventHandlingNeeded at the crossing (earlyReturnAllowed, the FMU declaring
    # mightReturnEarlyFromDoStep), the run enters Event Mode at lastSuccessfulTime and goes on
    # from there (FMI 3.0.2 section 4.2.1)
    out = tmp_path / "o.csv"
    r = run("simulate", toy("Ticker", 3), "--interface", interface,
            "--outputs", "x,n,alarms,t_alarm", "--out", out)
    assert r.returncode == 0, r.stderr
    header, rows = read_csv(out)
    cols = dict(zip(header, rows.T))
    t = rows[:, 0]
    after = None if interface == "me" else before_events_but_at_start(t)
    check_ticker(t, cols, after)
    assert len(crossings()) == 8  # x(2) = 8.2
    check_alarms(t, cols, crossings(), after)


def test_without_early_return_an_event_is_handled_at_the_end_of_its_step(toy, tmp_path):
    # without mightReturnEarlyFromDoStep the run does not allow an early return: the FMU meets
    # the crossing inside a step and asks for Event Mode at the step's end, the next output
    # point or clock tick
    fmu = with_clock(toy("Ticker", 3), tmp_path / "Ticker.fmu",
                     ' mightReturnEarlyFromDoStep="true"', "")
    out = tmp_path / "o.csv"
    r = run("simulate", fmu, "--interface", "cs", "--outputs", "x,n,alarms,t_alarm",
            "--out", out)
    assert r.returncode == 0, r.stderr
    header, rows = read_csv(out)
    ends = np.unique(np.concatenate([0.05 * np.arange(41), TICKER_TICKS, COUNTDOWN_TICKS,
                                     CHANGING_TICKS]).round(12))
    handled = np.array([ends[np.searchsorted(ends, tc - 1e-12)] for tc in crossings()])
    assert not np.allclose(handled, crossings())
    t = rows[:, 0]
    check_alarms(t, dict(zip(header, rows.T)), handled, before_events_but_at_start(t))


@pytest.mark.parametrize("interface", ["me", "cs"])
def test_a_held_input_changes_in_event_mode(interface, toy, tmp_path):
    # Co-Simulation with Event Mode: the step ends at the input event and the new value is set
    # in Event Mode ("the importer plans discrete changes to inputs", FMI 3.0.2 section 4.2);
    # Model Exchange: an input event, as before
    data = tmp_path / "u.csv"
    data.write_text("time,u\n0,0\n0.52,3\n2,3\n")
    out = tmp_path / "o.csv"
    r = run("simulate", toy("Ticker", 3), "--interface", interface, "--data", data,
            "--stop", "2", "--step", "0.05", "--outputs", "n,y,u_at", "--out", out)
    assert r.returncode == 0, r.stderr
    header, rows = read_csv(out)
    assert header == ["time", "n", "y", "u_at"]
    t, n, y, u_at = rows.T
    after = t > 0.52 + 1e-9
    assert (y[after] == 3).all() and (y[t < 0.52 - 1e-9] == 0).all(), (t, y)
    assert np.allclose(u_at[after], 0.52, rtol=0, atol=1e-12) and (u_at[t < 0.52] == -1).all()
    # the ticks go on as without the input
    assert n[-1] == 8


# Trigger (tests/fixtures/toy-fmus/trigger.c): a triggered input clock `trig`, counted into its
# clocked output k; der(x) = k. The data tick it at the rows where its column is true.
TRIGGERS = np.array([0.3, 0.55, 1.2, 1.25])


def trigger_run(interface, toy, tmp_path):
    """A run of Trigger with ticks at TRIGGERS: its times, x and k."""
    data = tmp_path / "ticks.csv"
    rows = [(0.0, 0), (0.3, 1), (0.4, 0), (0.55, 1), (0.9, 0), (1.2, 1), (1.25, 1), (1.6, 0)]
    data.write_text("time,trig\n" + "".join(f"{t},{on}\n" for t, on in rows))
    out = tmp_path / "o.csv"
    r = run("simulate", toy("Trigger", 3), "--data", data, "--out", out, "--interface", interface)
    assert r.returncode == 0, r.stderr
    header, values = read_csv(out)
    assert header == ["time", "x", "k"]
    return values.T


def triggered_closed_form(t, after):
    """k and x at the times t, after the ticks at t or before them (a tick within 1e-12 of a
    time happens there: the grid's 0.3 is 0.29999999999999993)."""
    done = TRIGGERS[None, :] <= t[:, None] + 1e-12
    done &= after[:, None] | (TRIGGERS[None, :] < t[:, None] - 1e-12)
    return done.sum(axis=1), np.where(done, t[:, None] - TRIGGERS[None, :], 0.0).sum(axis=1)


def test_a_triggered_input_clock_ticks_where_its_column_is_true_in_model_exchange(toy, tmp_path):
    t, x, k = trigger_run("me", toy, tmp_path)
    for tj in TRIGGERS:
        # each tick is an event: a row before it and one after it, at the tick's time
        at = np.flatnonzero(np.abs(t - tj) <= 1e-12)
        assert len(at) == 2, (tj, t[(t > tj - 0.1) & (t < tj + 0.1)])
    # the last row at a time holds the values after its events
    after = np.append(t[1:] != t[:-1], True)
    want_k, want_x = triggered_closed_form(t, after)
    assert np.array_equal(k, want_k), (t, k, want_k)
    assert np.allclose(x, want_x, atol=1e-9)


def test_a_triggered_input_clock_ticks_where_its_column_is_true_in_co_simulation(toy, tmp_path):
    t, x, k = trigger_run("cs", toy, tmp_path)
    # rows at the output points, before the events there (as for the periodic clocks)
    want_k, want_x = triggered_closed_form(t, np.zeros(len(t), dtype=bool))
    assert np.array_equal(k, want_k), (t, k, want_k)
    assert np.allclose(x, want_x, atol=1e-9)
    assert k[-1] == len(TRIGGERS)


def test_a_column_for_a_clock_that_ticks_by_its_own_schedule_is_refused_saying_so(toy, tmp_path):
    data = tmp_path / "ticks.csv"
    data.write_text("time,tick\n0,1\n1,0\n")
    r = run("simulate", toy("Sampler", 3), "--data", data, "--out", tmp_path / "o.csv")
    assert r.returncode == 2
    assert "ticks by its own schedule" in r.stderr and "triggered" in r.stderr, r.stderr
    # a column named as an output clock is, as any output's column, no input and left alone
    data.write_text("time,even\n0,1\n1,0\n")
    r = run("simulate", toy("Ticker", 3), "--data", data, "--out", tmp_path / "o.csv")
    assert r.returncode == 0, r.stderr

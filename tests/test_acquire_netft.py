"""The Net F/T source against a fake sensor serving real UDP RDT packets on 127.0.0.1."""

from __future__ import annotations

import socket
import time

import numpy as np
import pytest

from contactlab.acquire.netft import NetFTSource, rdt_request
from contactlab.archive import create_archive
from contactlab.archive.validate import validate_archive
from contactlab.errors import DataError, UsageError
from fake_netft import FakeNetFT

RATE = 1000.0
CPF, CPT = 1_000_000.0, 1_000.0   # counts per N and per N m


def counts_of(offset: int) -> tuple:
    """Known counts for the record at ``offset``: distinct per axis and per sample."""
    return (1000 * offset, -2000 * offset, 3_000_000 + offset, 7 * offset, -5, offset % 13)


def record(first: int, offset: int, status: int = 0) -> tuple:
    return (first + offset, 10 * offset, status, counts_of(offset))


def source(port: int, **kw) -> NetFTSource:
    args = dict(host="127.0.0.1", port=port, duration_s=0.3, rate_hz=RATE,
                counts_per_force=CPF, counts_per_torque=CPT, timeout_s=0.5)
    args.update(kw)
    return NetFTSource(**args)


def record_trial(src: NetFTSource):
    (trial,) = src.trials(n_trials=1, seed=3)
    chunks = list(trial.chunks())
    data = {k: np.concatenate([c[k] for c in chunks]) for k in chunks[0]}
    return trial, chunks, data


def script_with_faults(first: int = 100, n: int = 300) -> tuple[list, list]:
    """n sequence numbers with a 2-record gap, a duplicate, a late record and a bad status.

    Returns the script and the offsets that must be kept.
    """
    script, kept = [], []
    for off in range(n):
        if off in (150, 151):                 # lost: a gap of two
            continue
        if off == 250:                        # sent late, after 252
            continue
        script.append(record(first, off, status=0x8000_0001 if off == 120 else 0))
        kept.append(off)
        if off == 200:
            script.append(record(first, off))  # duplicate
        if off == 252:
            script.append(record(first, 250))  # out of order
    return script, kept


def test_values_scaling_time_base_and_packet_counts():
    script, kept = script_with_faults()
    with FakeNetFT(script) as fake:
        trial, chunks, data = record_trial(source(fake.port))
        assert fake.stopped.wait(2), "the stop request never arrived"
    assert fake.requests[0] == (0x1234, 2, 0)
    assert fake.requests[-1] == (0x1234, 0, 0)
    assert trial.stop_sent
    kept = np.array(kept)
    np.testing.assert_array_equal(data["time"], kept / RATE)
    expected = np.array([counts_of(o) for o in kept], dtype=float)
    np.testing.assert_allclose(data["wrench"][:, :3], expected[:, :3] / CPF)
    np.testing.assert_allclose(data["wrench"][:, 3:], expected[:, 3:] / CPT)
    assert data["wrench"].dtype == np.float64 and data["time"].dtype == np.float64
    assert set(chunks[0]) == {"time", "wrench"}
    assert len(chunks) > 1                      # streamed, not one block at the end
    attrs = trial.final_attrs()
    assert attrs["dropped_packets"] == 3        # 150, 151 and the late 250
    assert attrs["out_of_order_packets"] == 1
    assert attrs["duplicate_packets"] == 1
    assert attrs["status_errors"] == 1 and attrs["status_bits"] == 0x8000_0001
    assert attrs["received_packets"] == len(script)
    assert attrs["first_rdt_sequence"] == 100 and attrs["last_rdt_sequence"] == 399
    extra = trial.extra_datasets()
    np.testing.assert_array_equal(extra["rdt_sequence"], 100 + kept)
    np.testing.assert_array_equal(extra["ft_sequence"], 10 * kept)
    assert extra["status"][kept == 120][0] == 0x8000_0001
    assert trial.ground_truth() is None
    assert trial.info.rate_hz == RATE and trial.info.source == "netft"
    assert trial.info.trial_id == "netft01" and trial.info.seed == 3


def test_sequence_wraparound():
    first = 2**32 - 5
    script = [record(first, o) for o in range(40) if o != 7]   # 7 is 2**32 + 2: lost
    with FakeNetFT(script) as fake:
        trial, _, data = record_trial(source(fake.port, duration_s=0.04))
    assert trial.final_attrs()["dropped_packets"] == 1
    assert trial.final_attrs()["out_of_order_packets"] == 0
    np.testing.assert_array_equal(data["time"] * RATE, [o for o in range(40) if o != 7])
    assert trial.extra_datasets()["rdt_sequence"][-1] == 34


def test_trial_ends_at_duration_and_several_trials_restart_the_stream():
    script = [record(0, o) for o in range(500)]
    with FakeNetFT(script) as fake:
        trials = list(source(fake.port, duration_s=0.1).trials(n_trials=2, seed=0))
        lengths = [sum(len(c["time"]) for c in t.chunks()) for t in trials]
        assert fake.wait_stops(2)
    assert lengths == [100, 100]
    assert [t.info.trial_id for t in trials] == ["netft01", "netft02"]
    assert fake.commands.count(2) == 2 and fake.commands.count(0) == 2


def test_sample_count_is_requested_and_a_lost_tail_is_counted():
    script = [record(0, o) for o in range(48)]     # asked for 50, the last two are lost
    with FakeNetFT(script) as fake:
        trial, _, data = record_trial(source(fake.port, sample_count=50, timeout_s=0.2))
    assert fake.requests[0] == (0x1234, 2, 50)
    assert len(data["time"]) == 48
    assert trial.final_attrs()["dropped_packets"] == 2


def test_archive_accepts_the_recorded_time_base(tmp_path):
    script, _ = script_with_faults()
    with FakeNetFT(script) as fake:
        (trial,) = source(fake.port).trials(n_trials=1, seed=0)
        path = tmp_path / "netft.h5"
        with create_archive(path, incremental=True) as archive:
            info = trial.info
            writer = archive.add_trial(info.trial_id, rate_hz=info.rate_hz, source=info.source,
                                       description=info.description)
            for chunk in trial.chunks():
                writer.append(**chunk)
            writer.close()
    assert validate_archive(path) == []


def test_timeout_is_one_line_and_still_sends_stop():
    with FakeNetFT([], respond=False) as fake:
        (trial,) = source(fake.port, timeout_s=0.2).trials(n_trials=1, seed=0)
        with pytest.raises(DataError) as err:
            list(trial.chunks())
        assert fake.stopped.wait(2)
    message = str(err.value)
    assert message == f"host: no packets from 127.0.0.1:{fake.port} within 0.2 s"
    assert "\n" not in message


def test_stream_that_stops_midway_is_an_error():
    with FakeNetFT([record(0, o) for o in range(30)]) as fake:
        (trial,) = source(fake.port, timeout_s=0.2).trials(n_trials=1, seed=0)
        with pytest.raises(DataError, match="stopped after 30 sequence numbers"):
            list(trial.chunks())


def test_records_before_a_stall_reach_the_consumer_before_the_error():
    # 130 records: one full chunk of 100 and 30 more that arrived before the stall
    with FakeNetFT([record(0, o) for o in range(130)]) as fake:
        (trial,) = source(fake.port, duration_s=1.0).trials(n_trials=1, seed=0)
        got = []
        with pytest.raises(DataError, match="stopped after 130 sequence numbers"):
            for chunk in trial.chunks():
                got.append(len(chunk["time"]))
        assert got == [100, 30]


def test_a_slow_consumer_is_not_a_wrong_rate():
    # the consumer pauses 1.2 s on the first chunk (an observer loading its kernels):
    # the records wait in the receive buffer, and the rate is judged only once the reader
    # is caught up with the box
    with FakeNetFT([record(0, o) for o in range(1500)], pace_hz=1000) as fake:
        (trial,) = source(fake.port, duration_s=1.5).trials(n_trials=1, seed=0)
        n = 0
        for k, chunk in enumerate(trial.chunks()):
            if k == 0:
                time.sleep(1.2)
            n += len(chunk["time"])
        assert n == 1500


def test_malformed_packet_is_one_line_error():
    script = [record(0, 0), record(0, 1), b"\x00" * 20]
    with FakeNetFT(script) as fake:
        (trial,) = source(fake.port).trials(n_trials=1, seed=0)
        with pytest.raises(DataError) as err:
            list(trial.chunks())
        assert fake.stopped.wait(2)
    assert str(err.value) == (f"host: malformed RDT packet from 127.0.0.1:{fake.port}: "
                              "20 bytes, expected 36")


def test_nothing_listening_is_a_one_line_error():
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()
    (trial,) = source(port, timeout_s=0.3).trials(n_trials=1, seed=0)
    with pytest.raises(DataError, match=r"^host: (127\.0\.0\.1:\d+ refused|no packets)"):
        list(trial.chunks())


@pytest.mark.parametrize("how", ["close", "interrupt"])
def test_stop_is_sent_when_the_consumer_stops_or_is_interrupted(how):
    with FakeNetFT([record(0, o) for o in range(400)]) as fake:
        (trial,) = source(fake.port).trials(n_trials=1, seed=0)
        chunks = trial.chunks()
        first = next(chunks)
        assert len(first["time"]) == 100
        if how == "close":
            chunks.close()
        else:
            with pytest.raises(KeyboardInterrupt):
                chunks.throw(KeyboardInterrupt)
        assert fake.stopped.wait(2)
    assert trial.stop_sent


def test_rate_far_from_rate_hz_is_an_error():
    # The fake streams at <= 300 Hz while the source assumes 1000 Hz.
    with FakeNetFT([record(0, o) for o in range(600)], pace_hz=300) as fake:
        (trial,) = source(fake.port, duration_s=2.0).trials(n_trials=1, seed=0)
        with pytest.raises(DataError, match=r"streams at about \d+.* Hz .* not rate_hz=1000"):
            list(trial.chunks())
        assert fake.stopped.wait(2)


def test_request_bytes():
    assert rdt_request(2, 0) == bytes.fromhex("1234 0002 00000000")
    assert rdt_request(0) == bytes.fromhex("1234 0000 00000000")


@pytest.mark.parametrize("kw, name", [({"duration_s": 0}, "duration_s"),
                                       ({"port": 70000}, "port"),
                                       ({"host": ""}, "host"),
                                       ({"counts_per_force": -1}, "counts_per_force"),
                                       ({"sample_count": -1}, "sample_count")])
def test_bad_parameters_are_usage_errors(kw, name):
    args = dict(host="127.0.0.1", duration_s=1.0)
    args.update(kw)
    with pytest.raises(UsageError, match=name):
        NetFTSource(**args)

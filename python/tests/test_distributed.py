"""selfmanip.distributed.sweep on a two-worker LocalCluster on loopback: the merged table equals
the local sweep bit for bit, in input order, whatever the chunking; failures stay per point;
bad input fails before anything is submitted."""

import numpy as np
import pytest

import selfmanip

distributed = pytest.importorskip("distributed")


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(processes=False, protocol="tcp", n_workers=2, threads_per_worker=1, host="127.0.0.1",
                                       dashboard_address=None)
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


def same_tables(a, b):
    assert list(a) == list(b)
    for k in a:
        x, y = np.asarray(a[k]), np.asarray(b[k])
        if x.dtype.kind == "f":
            assert np.array_equal(x.view(np.int64), y.view(np.int64)), k
        else:
            assert np.array_equal(x, y), k


def test_distributed_equals_local(client):
    args = dict(strategy=["++", "+-", "-+", "--"], t2=np.linspace(-0.1, 0.1, 5), gear_ratio=[22.0, 28.0])
    local = selfmanip.sweep(**args, threads=2)
    for chunk in (7, 1000):
        same_tables(selfmanip.distributed.sweep(client, **args, chunk_size=chunk), local)


def test_distributed_takes_the_typed_actuator(client):
    """Actuators travel to the workers as values; the chunks (split inside a set of motors)
    merge to the local table."""
    args = dict(strategy=["++", "--"], t2=[0.0, 0.05],
                actuator=[selfmanip.Saturated(), selfmanip.GearedMotor(ratio=20.0, current_limit_a=10.0),
                          selfmanip.GearedMotor(ratio=28.0)])
    same_tables(selfmanip.distributed.sweep(client, **args, chunk_size=5), selfmanip.sweep(**args, threads=2))


def test_failures_stay_per_point(client):
    args = dict(strategy="++", t2=[0.0, 0.05, 0.1], gear_ratio=28.0, m_b=[9.0, -1.0, 9.0], grid=False)
    got = selfmanip.distributed.sweep(client, **args, chunk_size=1)
    same_tables(got, selfmanip.sweep(**args, threads=1))
    assert got["status"][1] == "invalid_params" and "m_b" in got["error"][1]


def test_bad_input_fails_before_submitting(client):
    with pytest.raises(ValueError, match="strategy"):
        selfmanip.distributed.sweep(client, "+?", t2=[0.0])
    with pytest.raises(ValueError, match="m_b"):
        selfmanip.distributed.sweep(client, "++", t2=[0.0], params={"m_b": -2.0})
    with pytest.raises(ValueError, match="chunk_size"):
        selfmanip.distributed.sweep(client, "++", t2=[0.0], chunk_size=0)

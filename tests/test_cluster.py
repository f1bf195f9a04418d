"""The data pipeline on a Dask cluster (joblib's Dask backend, a LocalCluster of two worker processes): collection
builds, channels added with Collection.with_channels and computed maps give what one machine gives."""

import sys

import numpy as np
import pytest

import opnet
from opnet.data import mapped_collection

distributed = pytest.importorskip("distributed")
joblib = pytest.importorskip("joblib")
pytestmark = pytest.mark.slow


class SlowArea(opnet.InnerProduct):
    """The area inner product without a project_batch: computed shape by shape, in joblib's processes (here: the
    cluster's workers)."""

    name = "slow area"

    def project(self, vertices, faces, evecs):
        return opnet.inner_products.AreaInnerProduct().project(vertices, faces, evecs)


@pytest.fixture(scope="module")
def client():
    import cloudpickle

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # the workers cannot import this test module
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    with cluster, distributed.Client(cluster) as client:
        yield client
    cloudpickle.unregister_pickle_by_value(sys.modules[__name__])


def _on_cluster(client, build):
    """``build()`` under joblib's Dask backend, and how many tasks the workers ran meanwhile."""
    with distributed.get_task_stream(client) as stream, joblib.parallel_config(backend="dask"):
        out = build()
    return out, len(stream.data)


def test_collections_built_on_a_cluster_equal_those_of_one_machine(client, tiny_collection, humans, tmp_path):
    assert opnet._parallel.cluster_backend() is None  # joblib's own backends are this machine's
    local = tiny_collection()
    remote, tasks = _on_cluster(client, tiny_collection)
    assert tasks >= 1 and np.array_equal(remote.operators, local.operators)  # the fast path's chunks: tasks
    channels = [SlowArea(), "extrinsic"]
    local_more = local.with_channels(channels, recompute=True, n_jobs=1, progress=False)
    remote_more, tasks = _on_cluster(client, lambda: remote.with_channels(channels, recompute=True, progress=False))
    assert tasks >= 2 and np.array_equal(remote_more.operators, local_more.operators)
    here, tasks = _on_cluster(client, lambda: remote.with_channels(["extrinsic"], recompute=True, n_jobs=1))
    assert tasks == 0 and np.array_equal(here.operators, local.operators[:, 2:])  # n_jobs=1: in this process
    few = humans.subset(np.concatenate([humans.indices(s)[:2] for s in ("val", "test", "train")]))
    # in two local processes (in this one, its BLAS's threads sum in another order: 1e-13 apart)
    one = mapped_collection(few, "2k", root=tmp_path / "local", n_jobs=2, chunk=2, progress=False)
    on, tasks = _on_cluster(
        client, lambda: mapped_collection(few, "2k", root=tmp_path / "dask", chunk=2, progress=False)
    )
    assert tasks == 3  # one per part of two shapes
    assert np.array_equal(on.operators, one.operators) and np.array_equal(
        on.params["map_error"], one.params["map_error"]
    )

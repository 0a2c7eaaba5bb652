"""Cluster mode: the batch's assets on an existing Dask distributed cluster (``pip install 'autorig[cluster]'``),
whose workers read and write no files: the inputs' bytes travel with the tasks, the outputs' come back."""
from __future__ import annotations

from typing import TYPE_CHECKING, Iterator

from ..errors import AutorigError, missing_package
from ..version import __version__
from .worker import Job, drain

if TYPE_CHECKING:
    from .plan import Plan


class ClusterError(AutorigError):
    """Cluster mode cannot run: dask.distributed missing, the scheduler unreachable, or workers unfit."""
    exit_code = 1


def run_on_cluster(address: str, work: Iterator[tuple[Plan, Job]], finished) -> None:
    try:
        from distributed import Client
        from distributed.comm import parse_address
        from distributed.comm.registry import get_backend
    except ImportError:
        raise missing_package("cluster mode (--scheduler)", "dask.distributed", "cluster") from None
    try:
        # Checked first: a Client that fails on a bad scheme hangs the interpreter's exit for a minute.
        get_backend(parse_address(address)[0])
    except ValueError as e:
        raise ClusterError(f"bad Dask scheduler address {address!r}: {e}") from None
    try:
        # Waits distributed.comm.timeouts.connect (30 s; DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT).
        client = Client(address, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as e:
        raise ClusterError(f"cannot reach the Dask scheduler at {address}: {' '.join(str(e).split())}") from None
    with client:
        try:
            versions = client.run(_autorig_version)
        except Exception as e:  # a worker that cannot even import autorig
            raise ClusterError(f"the Dask workers at {address} cannot run autorig: {type(e).__name__}: {e}"
                               ) from None
        wrong = sorted(w for w, v in versions.items() if v != __version__)
        if not versions:
            raise ClusterError(f"the Dask scheduler at {address} has no workers")
        if wrong:
            raise ClusterError(f"Dask workers run another autorig version than {__version__}: "
                               f"{', '.join(f'{w} has {versions[w]}' for w in wrong[:3])}")
        threads = sum(client.nthreads().values())
        with client.get_executor(pure=False) as executor:
            # Dask retries a task whose worker died (distributed.scheduler.allowed-failures) before it
            # gives up with KilledWorker; any error from the cluster itself fails just that asset.
            drain(executor, max(4, 2 * threads), work, finished,
                  lost_message="the Dask cluster could not run this asset")


def _autorig_version() -> str:
    return __version__

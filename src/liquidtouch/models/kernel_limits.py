"""Size limits of kernel models (GP regressors, the SVM classifier), and their BLAS threads.

A kernel model is refit on its stored training rows whenever a model file is
loaded: O(n³) time, O(n²) memory, so its training rows are bounded
(:data:`MAX_KERNEL_ROWS` per model, :data:`MAX_KERNEL_ROWS_TOTAL` per model file).
"""

from __future__ import annotations

from typing import Any

from liquidtouch.errors import TableError

# A kernel model (GP, SVM) is refit on its stored training rows whenever a model file is
# loaded: O(n³) time, O(n²) memory. Measured (2 cores, BLAS single-threaded, peak RSS
# above the 150 MB of the imports): one GP refit takes 0.13 s and +40 MB at 1000 rows,
# 0.6-1.3 s and +145 MB at 2000, 2.6 s and +225 MB at 3000, 9.6 s and +600 MB at 5000
# (20 000 rows: 136 s and 9.6 GB); the SVM refit with random labels (every row a support
# vector, the worst case) 0.4 s at 1000 rows, 2.4 s at 2000, 11 s at 5000.
#: Most training rows of one kernel model (GP regressor or SVM classifier).
MAX_KERNEL_ROWS = 2000
#: Most kernel-model training rows of one model file, summed over its targets.
MAX_KERNEL_ROWS_TOTAL = 4000


def check_kernel_rows(estimator: Any, n_rows: int) -> None:
    """:class:`TableError` if a kernel model would have more than :data:`MAX_KERNEL_ROWS` rows."""
    if n_rows > MAX_KERNEL_ROWS:
        raise TableError(
            f"{type(estimator).__name__}: {n_rows} training rows, but a kernel model (GP, SVM) "
            f"is limited to {MAX_KERNEL_ROWS} rows (a model file refits it on loading, which "
            "takes O(n³) time and O(n²) memory); subsample the training table, or use the "
            "quadratic model (`model` quadratic)"
        )


def single_threaded_blas() -> Any:
    """Context limiting BLAS to one thread.

    Our matrices are small (a few hundred rows): BLAS threads only add
    synchronisation, and on a loaded machine spinning threads made a GP fit
    10× slower (16 s instead of 1.6 s for 150 points).
    """
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")

"""Wall-clock timing shared by the benchmarks (the library's :mod:`contactlab.timing`)."""

from contactlab.timing import best_time, best_time_and_result

__all__ = ["best_time", "best_time_and_result"]

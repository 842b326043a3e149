"""Fusing the optical stream with the reference F/T: clock alignment and window averages.

clock = fit_clock(ft_rows["sensor_time"], ft_rows["host_time"])
ft_t = clock.to_host(ft_rows["sensor_time"])
mean, valid, count = window_average(ft_t, ft_rows["wrench"], t0_host, t1_host)
"""

from spectratac.fusion.clock import ClockFitError, ClockModel, fit_clock
from spectratac.fusion.window import GAP_PERIODS, window_average

__all__ = ["GAP_PERIODS", "ClockFitError", "ClockModel", "fit_clock", "window_average"]

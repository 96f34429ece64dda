"""Heading for PDR. Inside bootnav.postproc.pdr a heading h is a bearing, clockwise from (magnetic or true)
north, as in the sources, so a step of length L moves east by L sin(h) and north by L cos(h) [NKUA2009].
``run_pdr`` turns bearings into ``yaw_enu_rad`` (counter-clockwise from east) for ``PdrResult`` and the
output files (``bootnav.CONVENTIONS["heading"]``, ``path.yaw_enu_from_bearing``).

Modules: magnetometer (tilt-compensated heading), mag_calibration ([NKUA2009] percentile method and an
ellipsoid fit), declination, gyro (integration about gravity, [Lazarevskiy2021, eqs. 2.5/2.6]), complementary.
"""

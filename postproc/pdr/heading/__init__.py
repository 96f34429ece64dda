"""Heading for PDR. Convention everywhere in bootnav.postproc.pdr: ``heading_rad`` = bearing, clockwise from
(magnetic or true) north, so a step of length L moves east by L sin(h) and north by L cos(h)
(seed-000 §5.1 R3).

Modules: magnetometer (tilt-compensated heading), mag_calibration (seed-000 percentile method and an
ellipsoid fit), declination, gyro (integration about gravity, seed-003 eqs. 2.5/2.6), complementary.
"""

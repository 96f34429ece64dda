"""Low-level primitives shared by acquisition (``bootnav.logger``) and processing (``bootnav.postproc``).

One definition of each idea: time base and gap rule (``timebase``), run-length phases (``runs``), the canonical
IMU CSV reader (``csvio``), JSON cleaning (``jsonio``), rotation conversions (``rotations``), the
conventions and software version written into every output (``conventions``). Nothing here
imports ``bootnav.logger``, ``bootnav.postproc`` or ``bootnav.simulator``.
"""

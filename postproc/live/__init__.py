"""``bootnav live``: the path of one or several boots drawn in the browser while they are recorded.

``cli`` (the command), ``session`` (recorder children, feeding thread), ``sources`` (a growing SWMR recording,
a replayed one), ``boot`` (per boot: streaming navigation, strides, floors, no-motion time), ``link`` (rate,
drops, CRC errors, saturation), ``server`` (stdlib HTTP + Server-Sent Events) and ``static/`` (the page).
"""

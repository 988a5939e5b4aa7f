"""The commander page's components (NiceGUI), one module each.

:mod:`.header` (the always-visible header: state, safety buttons, Resume while paused, E-STOP,
the compact gripper readout), :mod:`.speed_override` (the speed override slider above the
tabs), :mod:`.view3d` (the 3D view), :mod:`.jog_panel` (joint and Cartesian jogging),
:mod:`.io_panel` (outputs and the SSG-48 gripper), :mod:`.program_panel` (the RBTscript
editor and runner), :mod:`.recordings_panel` (record the robot, the recordings list, teach
from a recording), :mod:`.telemetry` (readouts, log and live charts) and :mod:`.help_dialog`
(the keyboard shortcuts).  :mod:`parolkit.gui.app` puts them on the page; the look and the
keyboard rules are the static files ``gui/static/commander.css`` and ``commander.js``.

Each component builds its widgets in its constructor and has an ``update`` the page's timers
call; none of them imports another component's module except :mod:`.telemetry`'s chart
options.
"""

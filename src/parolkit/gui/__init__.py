"""The web commander (``parolkit gui``).

Pure UI logic (no NiceGUI import) lives in :mod:`parolkit.gui.status` (readout formatting of
the client's :class:`~parolkit.client.core.RobotStatus`), :mod:`parolkit.gui.jog` (jog
commands, limits, keyboard map), :mod:`parolkit.gui.eventlog`, :mod:`parolkit.gui.templates`,
:mod:`parolkit.gui.highlight` (RBTscript token colouring) and :mod:`parolkit.gui.geometry`
(arm solids from the DH table).  :mod:`parolkit.gui.link` reaches the controller through the
client's :class:`~parolkit.client.async_robot.AsyncRobot` (never its own sockets);
:mod:`parolkit.gui.app` builds the page.  Access rules, also without NiceGUI:
:mod:`parolkit.gui.programs` (the programs folder), :mod:`parolkit.gui.security` (Host / Origin
allow-list and login, an ASGI middleware) and :mod:`parolkit.gui.lease_watch` (who controls the
robot); ``programs_panel`` and ``control_badge`` are their NiceGUI widgets.
"""

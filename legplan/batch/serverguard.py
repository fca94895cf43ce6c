"""The first import of the fork server that starts `--jobs N` workers (`legplan.batch.backends`).

Importing it ties the importing process to its parent: SIGKILL when the command that started it
ends (`legplan.interrupts.die_with_parent`, the command's pid read from `$LEGPLAN_PARENT_PID`). The
fork server's workers die with the server in turn, so a killed command leaves no worker behind,
although the workers hold the server open. Only the fork server's preload list names this module.
"""

from legplan.interrupts import die_with_parent

die_with_parent()

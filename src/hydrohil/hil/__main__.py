"""``python -m hydrohil.hil plant|controller``: the HIL processes as the library starts them."""

from hydrohil.hil.commands import process_app
from hydrohil.terminal import show_warnings_as_lines

show_warnings_as_lines()
process_app(prog_name="python -m hydrohil.hil")

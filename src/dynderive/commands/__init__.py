"""The command line (``cli``) and what only it does: writing files (``output``), building many
robots (``build``) and simulating (``simulate``). Errors become exit codes here only."""

"""The code-generation layer every target prints with (``render/targets/*`` import from here,
never from one another): arguments and printed functions (``functions.py``), the Python
modules' shared context (``python_context.py``), dead-line pruning (``prune.py``), constant
folding (``fold.py``), common subexpressions (``cse.py``), the program printer base
(``printer.py``), C's expression syntax for C and MATLAB (``c_syntax.py``), number literals
(``literals.py``) and the identifiers and comments of C-family files (``names.py``)."""

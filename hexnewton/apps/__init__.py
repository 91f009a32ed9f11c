"""The command lines, one module each (``python -m hexnewton.apps.<name>``; ``train.py`` and ``play.py`` at the
repository's root), and their shared argument helpers (``cli``). Library code lives in the layers below."""

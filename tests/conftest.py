"""The suite runs the models on CasADi's virtual machine unless a test asks for compiled code
(tests/test_compiled.py): the disk cache of compiled Functions (optdesign/model/compiled.py)
would otherwise make which path a test takes depend on what earlier runs left in the cache,
and start compilers in the background while the suite runs."""
import os

os.environ.setdefault("OPTDESIGN_NO_COMPILE", "1")

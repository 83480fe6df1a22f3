"""``python -m demcal.cli``: the demcal command."""

import sys

from demcal.cli import main

sys.exit(main())

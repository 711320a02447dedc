"""``python -m replication``: the same as the ``replication`` command."""

import sys

from replication.cli import main

sys.exit(main())

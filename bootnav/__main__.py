import sys

from bootnav.cli import main

sys.exit(main())

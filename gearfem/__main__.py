import sys

from gearfem.cli import main

sys.exit(main())

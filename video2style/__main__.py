import sys

from video2style.cli import main

sys.exit(main())

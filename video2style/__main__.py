import sys

from video2style.cli import console_main

sys.exit(console_main())

from desktop.bench.core import main

main()

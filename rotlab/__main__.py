from rotlab.cli import main

main()

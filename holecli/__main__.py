from holecli.cli import main

main()

"""Build script of the pd_rths_benchmark ament_python package."""

from setuptools import find_packages, setup

PACKAGE = 'pd_rths_benchmark'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='Pseudo-dynamic testing maintainers',
    maintainer_email='maintainers@pseudodynamic.dev',
    description=('The virtual real-time hybrid simulation (vRTHS) benchmark: its problem, the '
                 'loop, the nine criteria J1-J9 and figures.'),
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'rths_benchmark = pd_rths_benchmark.rths_benchmark:main',
        ],
        'pd.commands': [
            'rths_benchmark = pd_rths_benchmark.commands:RTHS_BENCHMARK',
        ],
    },
)
